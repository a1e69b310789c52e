//! firmware (skeleton; see its issue).
#![no_std]
