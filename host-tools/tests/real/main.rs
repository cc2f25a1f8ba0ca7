//! host-tools on real data and official check values, one test binary (one
//! link instead of six; `cargo test -p host-tools --test real <filter>`
//! runs a part): the fits against an independent ellipsoid fit, the
//! attitude and gyro fits on real vehicles, the integrity on BROAD's
//! disturbed trials, the world models against their official values.

use std::path::{Path, PathBuf};

/// A file of the repository's `tests/data` (the real recordings, with their licences).
pub fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data").join(rel)
}

mod attitude_glider;
mod auto_judge;
mod geomag;
mod glider_world;
mod integrity_broad;
mod limited_tilt;
mod real_data;
mod real_gyro;
