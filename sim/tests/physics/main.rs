//! The simulator and the chain on it, one test binary (one link instead of
//! four; `cargo test -p magcal-sim --test physics <filter>` runs a part):
//! the effects and disturbances against their physics, the log shapes of
//! `merge`'s tests, the chain's
//! acceptance numbers on the default site and on varied sites.

mod disturbances;
mod effects;
mod gyro_dip;
mod held_rule;
mod logs;
mod scenario;
mod varied;
