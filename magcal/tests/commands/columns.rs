//! Recordings from other tools: cells separated by semicolon,
//! tab or spaces, and columns with other names and units mapped with
//! `--columns`, fit as the project's own CSV does.

use std::path::Path;
use super::{magcal, p};

fn fit_json(input: &Path, extra: &[&str]) -> serde_json::Value {
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    let out = magcal(&[&["fit", "--input", p(input), "--model", "axis", "--json"][..], &site[..], extra].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn numbers(v: &serde_json::Value, key: &str) -> Vec<f64> {
    let flat = |x: &serde_json::Value| x.as_array().map(|a| a.iter().map(|e| e.as_f64().unwrap()).collect()).unwrap_or_else(|| vec![x.as_f64().unwrap()]);
    match &v[key] {
        serde_json::Value::Array(rows) if rows.iter().all(|r| r.is_array()) => rows.iter().flat_map(flat).collect(),
        x => flat(x),
    }
}

/// Rewrites the comma file `from`: `sep` between cells, the field columns
/// renamed by `rename` and scaled by `scale` (printed at full precision).
fn rewrite(from: &Path, to: &Path, sep: &str, rename: impl Fn(&str) -> String, scale: f64) {
    let text = std::fs::read_to_string(from).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut out = header.iter().map(|h| rename(h)).collect::<Vec<_>>().join(sep) + "\n";
    for line in lines {
        let cells: Vec<String> = line
            .split(',')
            .zip(&header)
            .map(|(c, h)| if ["mx", "my", "mz"].contains(h) { format!("{:e}", c.parse::<f64>().unwrap() * scale) } else if c.is_empty() { "nan".into() } else { c.into() })
            .collect();
        out += &(cells.join(sep) + "\n");
    }
    std::fs::write(to, out).unwrap();
}

#[test]
fn other_separators_and_a_gauss_mapping_give_the_same_fit() {
    let dir = tempfile::tempdir().unwrap();
    let counts = dir.path().join("swing.csv");
    let o = magcal(&["simulate", "swing", "--seed", "11", "--rate-hz", "1", "--out", p(&counts)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The simulated counts as nT: ×10 (so the fit's bias is 10× the counts
    // fit's and its matrix a tenth: an independent reference).
    let nt = dir.path().join("nt.csv");
    rewrite(&counts, &nt, ",", str::to_string, 10.0);
    let reference = fit_json(&counts, &[]);
    let fit_nt = fit_json(&nt, &[]);
    for (a, b) in numbers(&fit_nt, "bias").iter().zip(numbers(&reference, "bias")) {
        assert!((a - 10.0 * b).abs() < 1e-6 * b.abs().max(1.0), "nT bias {a} vs 10 × {b}");
    }

    // Semicolon, tab and spaces: the same numbers as the comma file.
    for (sep, name) in [(";", "semi.csv"), ("\t", "tab.tsv"), ("  ", "spaces.txt")] {
        let f = dir.path().join(name);
        rewrite(&nt, &f, sep, str::to_string, 1.0);
        let fit = fit_json(&f, &[]);
        for key in ["bias", "matrix", "field_nt"] {
            assert_eq!(numbers(&fit, key), numbers(&fit_nt, key), "{name}: {key}");
        }
    }

    // Gauss under another tool's names, semicolons: mapped, converted to nT.
    let gauss = dir.path().join("gauss.csv");
    let rename = |h: &str| match h {
        "mx" | "my" | "mz" => format!("mag_{}_gauss", &h[1..]),
        h => h.to_string(),
    };
    rewrite(&nt, &gauss, ";", rename, 1e-5);
    let fit = fit_json(&gauss, &["--columns", "mx=mag_x_gauss:gauss,my=MAG_Y_GAUSS:gauss,mz=mag_z_gauss:G"]);
    for key in ["bias", "matrix", "field_nt"] {
        for (a, b) in numbers(&fit, key).iter().zip(numbers(&fit_nt, key)) {
            // Measured: equal to the last digits (the gauss file's cells
            // are rounded once more); the bound is 1e-9 relative.
            assert!((a - b).abs() <= 1e-9 * b.abs().max(1e-3), "{key}: {a} vs {b}");
        }
    }

    // Without the mapping: the error says which mapping to give.
    let o = magcal(&["fit", "--input", p(&gauss), "--model", "axis", "--field-nt", "48950"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(e.contains("missing column `mx`") && e.contains("`mx=mag_x_gauss:gauss,my=mag_y_gauss:gauss,mz=mag_z_gauss:gauss`") && e.contains("--columns"), "{e}");
}

#[test]
fn bad_mappings_are_refused_with_the_headers_names() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("r.csv");
    std::fs::write(&f, "Time,Magnetometer X (uT),Magnetometer Y (uT),Magnetometer Z (uT)\n0,1,2,3\n").unwrap();
    let run = |map: &str| {
        let o = magcal(&["fit", "--input", p(&f), "--model", "axis", "--field-nt", "48950", "--columns", map]);
        assert!(!o.status.success() && o.stdout.is_empty());
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    let e = run("mx=Magnetometer X (uT):uT,my=Magnetometer Y (uT):uT,mz=Magnetometer W (uT):uT");
    assert!(e.contains("gives `mz` as `Magnetometer W (uT)`, which the header does not have (the header has: Time, Magnetometer X (uT), Magnetometer Y (uT), Magnetometer Z (uT))"), "{e}");
    assert!(run("mx=Magnetometer X (uT):tesla").contains("unknown unit `tesla`"));
    assert!(run("heading=Time").contains("no such column"));
    assert!(run("roll_deg=Time:uT").contains("a unit fits only"));
    // And a file whose header mixes separators.
    std::fs::write(&f, "t,mx;my,mz\n0,1,2,3\n").unwrap();
    let o = magcal(&["fit", "--input", p(&f), "--model", "axis", "--field-nt", "48950"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("more than one of comma, semicolon and tab"));
}
