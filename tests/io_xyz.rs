//! Text point lists: separators, comments, column names, Leica PTS count lines, precision.

use std::path::{Path, PathBuf};

use sharpedge::io::{self, ReadOptions};
use sharpedge::{Cloud, Column};

fn write(dir: &Path, name: &str, content: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

fn read(p: &Path) -> Cloud {
    io::read(p, &ReadOptions::default()).unwrap()
}

fn names(c: &Cloud) -> Vec<&str> {
    c.attributes.iter().map(|a| a.name.as_str()).collect()
}

#[test]
fn whitespace_and_comma_separated_with_comments() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "a.xyz",
        "# a comment\n1 2 3\n\n 4\t5   6 \n7,8,9\n10, 11, 12\n-1.5e2;0;1e-3\n",
    );
    let c = read(&p);
    assert_eq!(
        c.positions,
        vec![
            [1.0, 2.0, 3.0],
            [4.0, 5.0, 6.0],
            [7.0, 8.0, 9.0],
            [10.0, 11.0, 12.0],
            [-150.0, 0.0, 1e-3]
        ]
    );
    assert!(c.attributes.is_empty());
    assert_eq!(c.source.format, "XYZ text, 3 columns (x y z)");
    assert!(!c.source.double_precision);
}

#[test]
fn six_columns_are_normals_and_others_are_numbered() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "n.pwn", "0 0 0 0 0 1\n1 0 0 0 1 0\n");
    let c = read(&p);
    assert_eq!(names(&c), ["nx", "ny", "nz"]);
    assert_eq!(c.attributes[1].values, Column::F64(vec![0.0, 1.0]));
    let p = write(dir.path(), "f.txt", "0 0 0 5 6\n1 1 1 7 8\n");
    let c = read(&p);
    assert_eq!(names(&c), ["field_4", "field_5"]);
    assert_eq!(c.attributes[1].values, Column::F64(vec![6.0, 8.0]));
}

#[test]
fn header_lines_name_the_columns() {
    let dir = tempfile::tempdir().unwrap();
    // CloudCompare's ascii export.
    let p = write(
        dir.path(),
        "cc.txt",
        "//X,Y,Z,R,G,B,Scalar field\n1,2,3,255,0,10,0.5\n",
    );
    let c = read(&p);
    assert_eq!(names(&c), ["R", "G", "B", "Scalar_field"]);
    assert_eq!(c.attributes[3].values, Column::F64(vec![0.5]));
    let p = write(dir.path(), "named.xyz", "x y z intensity\n1 2 3 40\n");
    let c = read(&p);
    assert_eq!(names(&c), ["intensity"]);
    assert_eq!(c.positions, vec![[1.0, 2.0, 3.0]]);
}

#[test]
fn leica_pts_count_lines_are_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "scan.pts",
        "2\n1 2 3 -100 10 20 30\n4 5 6 -200 40 50 60\n1\n7 8 9 -300 70 80 90\n",
    );
    let c = read(&p);
    assert_eq!(c.len(), 3);
    assert_eq!(names(&c), ["intensity", "red", "green", "blue"]);
    assert_eq!(
        c.attributes[0].values,
        Column::F64(vec![-100.0, -200.0, -300.0])
    );
}

#[test]
fn precision_follows_the_written_digits() {
    let dir = tempfile::tempdir().unwrap();
    // Millimetres at 500 km: f32 keeps 1/32 there, so double is needed, and kept.
    let p = write(dir.path(), "geo.xyz", "512345.123 4101234.567 80.001\n");
    let c = read(&p);
    assert!(c.source.double_precision);
    assert_eq!(c.positions, vec![[512345.123, 4101234.567, 80.001]]);
    // Micrometres on a 100 mm part fit f32.
    let p = write(dir.path(), "part.xyz", "12.345678 -50.5 99.125\n");
    assert!(!read(&p).source.double_precision);
}

#[test]
fn empty_text_file_is_an_empty_cloud() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "empty.xyz", "# nothing yet\n\n");
    let c = read(&p);
    assert!(c.is_empty());
    assert_eq!(c.source.format, "XYZ text, no points");
}
