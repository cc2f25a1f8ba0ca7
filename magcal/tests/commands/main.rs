//! `magcal` from the command line, one test binary (one link instead of
//! thirteen; `cargo test -p magcal --test commands <filter>` runs a part):
//! each module drives the built `magcal` as a user would, on simulated and
//! real recordings.

mod apply;
mod card;
mod cli;
mod columns;
mod export;
mod import;
mod input_checks;
mod log;
mod log_workflow;
mod merge;
mod readme;
mod reference;
mod simulate;
