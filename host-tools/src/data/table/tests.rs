//! The table module's tests.

use super::*;

fn read(text: &[u8], required: &[&'static str], optional: &[&str]) -> Result<Table, TableError> {
    read_table_from(text, Path::new("x.csv"), required, optional)
}

/// The recording's, the navigation log's and the board log's types hold
/// exactly the registry's columns of their log (`mx, my, mz` are their
/// `mag`), so that reading, writing and merging, which iterate the
/// registry, miss none; and merge carries what both hold.
#[test]
fn each_log_type_holds_the_registry_columns_of_its_log() {
    use crate::data::nav_log::NavLog;
    use crate::data::Recording;
    let sorted = |mut v: Vec<&'static str>| {
        v.sort_unstable();
        v
    };
    let of = |pick: fn(&Logs) -> bool| sorted(COLUMNS.iter().filter(|c| pick(&c.logs) && !col::MAG.contains(&c.name)).map(|c| c.name).collect());
    assert_eq!(sorted(Recording::NAMES.to_vec()), of(|l| l.recording));
    assert_eq!(sorted(NavLog::NAMES.to_vec()), of(|l| l.nav));
    assert_eq!(sorted(crate::data::board_log::BoardLog::NAMES.to_vec()), of(|l| l.board));
    let merged: Vec<&str> = merged_columns().map(|c| c.name).collect();
    assert_eq!(merged, ["roll_deg", "pitch_deg", "ref_heading_deg", "lat_deg", "lon_deg", "gx", "gy", "gz", "speed_mps", "motor_current_a"]);
}

/// The registry holds each name once, and every name of `col` (what
/// the readers and writers use) is in it.
#[test]
fn the_column_registry_holds_every_column_once() {
    let mut names: Vec<&str> = COLUMNS.iter().map(|c| c.name).collect();
    names.sort_unstable();
    let n = names.len();
    names.dedup();
    assert_eq!(names.len(), n, "a name twice");
    use col::*;
    let mut all = vec![T, ROLL_DEG, PITCH_DEG, HEADING_DEG, REF_HEADING_DEG, LAT_DEG, LON_DEG, SPEED_MPS, MOTOR_CURRENT_A, TEMP_C, HEALTH, T_BOARD, TRUE_HEADING_DEG, TRUE_FIELD_NT, COMPASS_HEADING_DEG, VARIATION_DEG, COURSE_DEG, GPS_SPEED_MPS];
    all.extend(MAG);
    all.extend(GYRO);
    for c in all {
        assert!(column_spec(c).is_some(), "{c} is not in the registry");
    }
    // What the registry says drives the mapping: an angle's unit on a
    // heading column, none on a speed.
    assert!("compass_heading_deg=HDG:rad".parse::<ColumnMap>().is_ok());
    assert!(matches!("speed_mps=STW:deg".parse::<ColumnMap>(), Err(ColumnMapError::WrongUnit(_))));
}

/// The one writer: typed cells, text quoted by the CSV rules (a label
/// holding a comma stays one cell; written by hand it split the row),
/// NaN and `None` empty, a row of the wrong length refused, and what it
/// writes reads back by the one reader.
#[test]
fn the_writer_quotes_text_and_refuses_ragged_rows() {
    let mut w = TableWriter::new(Vec::new(), &["label", "t", "x", "n"]).unwrap();
    w.row(&[Cell::Text("N, by \"compass\""), Cell::Fixed(1.23456, 3), Cell::Number(f64::NAN), Cell::Count(7)]).unwrap();
    w.row(&[Cell::Empty, Cell::opt_fixed(None, 2), Cell::opt(Some(-0.5)), Cell::Count(0)]).unwrap();
    assert!(w.row(&[Cell::Empty]).is_err());
    w.flush().unwrap();
    let text = String::from_utf8(w.out.into_inner().unwrap()).unwrap();
    assert_eq!(text, "label,t,x,n\n\"N, by \"\"compass\"\"\",1.235,,7\n,,-0.5,0\n");
    let mut t = read(text.as_bytes(), &["n"], &["x"]).unwrap();
    assert_eq!(t.take("n"), Some(vec![7.0, 0.0]));
}

/// One set of rules for every table: any case, a BOM, ragged rows and
/// bad cells named by file and line, NaN written as an empty cell.
#[test]
fn the_rules_of_every_table() {
    let mut t = read("\u{feff}T,MX,Roll_Deg\n0,1,\n1,2,nan\n".as_bytes(), &["t", "mx"], &["roll_deg", "gx"]).unwrap();
    assert_eq!(t.take("mx"), Some(vec![1.0, 2.0]));
    assert!(t.take("roll_deg").unwrap().iter().all(|v| v.is_nan()));
    assert!(t.take("gx").is_none());
    let e = read(b"t,mx\n0,1\n1\n", &["t"], &[]).unwrap_err();
    assert!(matches!(e, TableError::Ragged { line: 3, found: 1, expected: 2, .. }), "{e}");
    let e = read(b"t,mx\n0,x\n", &["t", "mx"], &[]).unwrap_err();
    assert_eq!(e.to_string(), "x.csv:2: column `mx`: `x` is not a number");
    let s = StreamColumns::new("\u{feff}T , Roll_deg", &["t", "roll_deg", "gx"], 2).unwrap();
    let v = s.values("1.5,2").unwrap();
    assert!(v.get("t") == 1.5 && v.get("roll_deg") == 2.0 && v.get("gx").is_nan() && v.get("not_wanted").is_nan());
    let e = StreamColumns::new("t,x", &["t", "roll_deg"], 2).unwrap_err();
    assert_eq!(e, StreamHeaderError { column: "roll_deg".into(), header: "t,x".into() });
    assert_eq!(e.to_string(), "missing column `roll_deg` (the header has: t,x)");
    // Quoted cells by the CSV rules: a comma inside quotes is one cell.
    let s = StreamColumns::new("\"t\",note,roll_deg", &["t", "roll_deg"], 2).unwrap();
    let v = s.values("2.5,\"a, b\",-3").unwrap();
    assert!(v.get("t") == 2.5 && v.get("roll_deg") == -3.0, "{v:?}");
    assert_eq!((cell(f64::NAN), cell(1.25)), (String::new(), "1.25".to_string()));
}

fn mapped(text: &str, map: &str) -> Result<Table, TableError> {
    read_table_mapped(text.as_bytes(), Path::new("x.csv"), &col::MAG, &[col::T, col::ROLL_DEG], &map.parse().unwrap())
}

/// Semicolon, tab and space-separated files read as the comma file does.
#[test]
fn the_separator_is_found_from_the_header() {
    let comma = "t,mx,my,mz,roll_deg\n0,1.5,-2,3,10\n1,4,5,6,nan\n";
    let want = |mut t: Table| (t.take("t"), t.take("mx"), t.take("mz"));
    let expect = want(mapped(comma, "").unwrap());
    assert_eq!(expect.1, Some(vec![1.5, 4.0]));
    for sep in [";", "\t", " ", "   "] {
        let text = comma.replace(',', sep);
        assert_eq!(want(mapped(&text, "").unwrap()), expect, "separator {sep:?}");
    }
    // An empty cell is only possible with a real separator: in a space
    // file a row with a missing value is ragged.
    assert!(matches!(mapped("t mx my mz\n0 1 2\n", ""), Err(TableError::Ragged { line: 2, .. })));
    let e = mapped("t,mx;my,mz\n0,1,2,3\n", "").unwrap_err();
    assert!(matches!(e, TableError::AmbiguousSeparator { .. }), "{e}");
}

/// Other tools' names and units: gauss to nT, radians to degrees.
#[test]
fn a_mapping_reads_other_names_and_units() {
    let text = "Time;Magnetometer X (uT);Magnetometer Y (uT);mag_z_gauss;Roll (rad)\n0;48.5;-1.25;0.2;0.5\n";
    let mut t = mapped(text, "t=time, mx=Magnetometer X (uT):uT, my=MAGNETOMETER Y (UT):µT, mz=mag_z_gauss:gauss, roll_deg=Roll (rad):rad").unwrap();
    // 48.5 µT = 48 500 nT; 0.2 G = 20 000 nT; 0.5 rad = 28.6479 deg.
    assert_eq!(t.take("mx"), Some(vec![48_500.0]));
    assert_eq!(t.take("my"), Some(vec![-1_250.0]));
    assert!((t.take("mz").unwrap()[0] - 20_000.0).abs() < 1e-9);
    assert!((t.take("roll_deg").unwrap()[0] - 28.647_889_756).abs() < 1e-8);
    // A gyro in degrees per second and a time in microseconds (other
    // tools' logs: ArduPilot's TimeUS, an IMU's deg/s): 90 deg/s =
    // π/2 rad/s; 1 500 000 µs = 1.5 s.
    let text = "TimeUS,MagX,MagY,MagZ,GyrX,GyrY,GyrZ\n1500000,1,2,3,90,-45,0\n";
    let map = "t=TimeUS:us,mx=MagX,my=MagY,mz=MagZ,gx=GyrX:deg/s,gy=GyrY:deg/s,gz=GyrZ:deg/s".parse().unwrap();
    let mut t = read_table_mapped(text.as_bytes(), Path::new("x.csv"), &col::MAG, &[col::T, col::GYRO[0], col::GYRO[1], col::GYRO[2]], &map).unwrap();
    assert_eq!(t.take("t"), Some(vec![1.5]));
    assert!((t.take("gx").unwrap()[0] - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    assert!((t.take("gy").unwrap()[0] + std::f64::consts::FRAC_PI_4).abs() < 1e-15);
    // An angle in radians is range-checked after conversion: 3.2 rad > 180°.
    let e = mapped("mx,my,mz,r\n1,2,3,3.2\n", "roll_deg=r:rad").unwrap_err();
    assert!(matches!(e, TableError::OutOfRange { line: 2, .. }), "{e}");
}

#[test]
fn bad_mappings_are_refused_by_name() {
    let e = mapped("a,b,c\n1,2,3\n", "mx=a,my=b,mz=nope").unwrap_err();
    assert_eq!(e.to_string(), "x.csv: the column mapping gives `mz` as `nope`, which the header does not have (the header has: a, b, c)");
    let parse = |s: &str| s.parse::<ColumnMap>().unwrap_err();
    assert!(matches!(parse("mx"), ColumnMapError::Syntax(_)));
    assert!(matches!(parse("mx="), ColumnMapError::Syntax(_)));
    assert!(matches!(parse("magx=a"), ColumnMapError::UnknownColumn(..)));
    assert!(matches!(parse("mx=a:tesla"), ColumnMapError::UnknownUnit(_, u) if u == "tesla"));
    assert!(matches!(parse("mx=a:deg"), ColumnMapError::WrongUnit(_)));
    assert!(matches!(parse("roll_deg=a:uT"), ColumnMapError::WrongUnit(_)));
    assert!(matches!(parse("t=a:rad"), ColumnMapError::WrongUnit(_)));
    assert!(matches!(parse("gx=a:deg"), ColumnMapError::WrongUnit(_)));
    assert!(matches!(parse("roll_deg=a:deg/s"), ColumnMapError::WrongUnit(_)));
    assert!(matches!(parse("speed_mps=a:ms"), ColumnMapError::WrongUnit(_)));
    assert!(matches!(parse("mx=a,MX=b"), ColumnMapError::Duplicate(_)));
}

/// A column read twice from the header, or two columns read
/// from one cell, is refused (the first `mx` was read silently); a
/// column twice that is not read stays harmless.
#[test]
fn a_column_read_twice_or_two_from_one_cell_are_refused() {
    let e = mapped("t,mx,my,mz,MX\n0,1,2,3,4\n", "").unwrap_err();
    assert!(matches!(e, TableError::DuplicateColumn { times: 2, .. }), "{e}");
    assert_eq!(e.to_string(), "x.csv: the header has `mx` 2 times: which one is `mx`? (rename or remove the others)");
    let e = mapped("t,a,b,c\n0,1,2,3\n", "mx=a,my=a,mz=c").unwrap_err();
    assert_eq!(e.to_string(), "x.csv: `mx` and `my` would both be read from the header's `a`: each column needs its own");
    let e = mapped("t,mx,my,mz\n0,1,2,3\n", "roll_deg=mx").unwrap_err();
    assert!(matches!(e, TableError::SharedColumn { .. }), "{e}");
    let mut t = mapped("t,mx,my,mz,note,note\n0,1,2,3,a,b\n", "").unwrap();
    assert_eq!(t.take("mx"), Some(vec![1.0]));
}

/// "missing column `mx`" alone once left other tools' users stuck.
#[test]
fn a_missing_field_column_suggests_the_mapping() {
    let e = mapped("time,mag_x_gauss,mag_y_gauss,mag_z_gauss\n0,1,2,3\n", "").unwrap_err();
    assert!(e.to_string().ends_with("give the column mapping `mx=mag_x_gauss:gauss,my=mag_y_gauss:gauss,mz=mag_z_gauss:gauss`"), "{e}");
    let e = mapped("Magnetometer X (uT)\tMagnetometer Y (uT)\tMagnetometer Z (uT)\n1\t2\t3\n", "").unwrap_err();
    assert!(e.to_string().contains("`mx=Magnetometer X (uT):ut,my=Magnetometer Y (uT):ut,mz=Magnetometer Z (uT):ut`"), "{e}");
    let e = mapped("t,magnetic\n0,1\n", "").unwrap_err();
    assert!(e.to_string().ends_with("`magnetic` look like magnetometer columns: give a column mapping `mx=NAME,my=NAME,mz=NAME`"), "{e}");
    // Nothing field-like (temperature, current): no suggestion.
    let e = mapped("t,temp_c,motor_current_a\n0,1,2\n", "").unwrap_err();
    assert!(e.to_string().ends_with("(the header has: t, temp_c, motor_current_a)"), "{e}");
}
