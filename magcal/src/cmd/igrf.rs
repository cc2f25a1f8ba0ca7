//! `magcal igrf`: the reference field (IGRF-14 or WMM2025) at a place and date.

use anyhow::Result;
use clap::ValueEnum;
use host_tools::geomag;
use serde_json::json;

use super::Place;

/// The model, as the command line names it.
#[derive(Clone, Copy, ValueEnum)]
pub enum FieldModel {
    /// IGRF-14 from the official coefficients.
    Igrf14,
    /// WMM2025 (world_magnetic_model crate).
    Wmm2025,
}

/// Arguments of `magcal igrf`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    place: Place,
    /// Height above the WGS-84 ellipsoid, metres (negative below).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    height_m: f64,
    /// Model.
    #[arg(long, value_enum, default_value = "igrf14")]
    model: FieldModel,
    /// Print one JSON document on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal igrf`.
pub fn run(a: Args) -> Result<()> {
    let Place { lat, lon, date } = a.place;
    let year = geomag::parse_date(&date)?;
    let model = match a.model {
        FieldModel::Igrf14 => geomag::Model::Igrf14,
        FieldModel::Wmm2025 => geomag::Model::Wmm2025,
    };
    let height_m = a.height_m;
    let f = geomag::field(model, lat, lon, height_m, year)?;
    if a.json {
        println!(
            "{}",
            json!({
                "model": model.name(), "north_nt": f.north_nt, "east_nt": f.east_nt, "down_nt": f.down_nt,
                "horizontal_nt": f.horizontal_nt(), "total_nt": f.total_nt(),
                "inclination_deg": f.inclination_deg(), "declination_deg": f.declination_deg(),
                "lat_deg": lat, "lon_deg": lon, "height_m": height_m, "decimal_year": year,
            })
        );
    } else {
        println!(
            "{} at {lat}°, {lon}°, {height_m} m, {year:.4}: X {:.1} Y {:.1} Z {:.1} H {:.1} F {:.1} nT, I {:.3}°, D {:.3}°",
            model.name(),
            f.north_nt,
            f.east_nt,
            f.down_nt,
            f.horizontal_nt(),
            f.total_nt(),
            f.inclination_deg(),
            f.declination_deg()
        );
    }
    Ok(())
}
