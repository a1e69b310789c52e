//! One module per subcommand: `Args` (clap) and `run`.

pub mod fk;
pub mod ik;
pub mod states;
