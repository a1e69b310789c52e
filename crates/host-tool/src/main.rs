//! `host-tool`: the command line of the Yoshimura crane.
fn main() {}
