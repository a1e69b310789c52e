//! One module per subcommand: `Args` (clap) and `run`.

pub mod aim;
pub mod declare;
pub mod demo;
pub mod design;
pub mod fk;
pub mod identify;
pub mod ik;
pub mod log;
pub mod model;
pub mod monitor;
pub mod output;
pub mod param;
pub mod pattern;
pub mod plan;
pub mod ports;
pub mod pose;
pub mod prim;
pub mod reach;
pub mod serve;
pub mod states;
pub mod station;
pub mod status;
pub mod stop;
pub mod sun;
pub mod task;
pub mod track;
