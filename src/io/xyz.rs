//! Plain-text point lists: `.xyz`, `.txt`, `.pts`, `.pwn`.
//!
//! One point per line, `x y z` then any number of extra columns, separated by spaces, tabs,
//! commas or semicolons. Every line must have the same number of columns. Lines starting with
//! `#` are comments. A first line of names (`x y z nx ny nz`, or CloudCompare's
//! `//X,Y,Z,R,G,B`) names the extra columns; without one, 6 columns are `x y z nx ny nz`
//! (CGAL's .xyz/.pwn), Leica `.pts` files are `x y z intensity [red green blue]` with a point
//! count line before the points, and other extra columns are `field_4`, `field_5`, ... (the
//! 1-based column number). Extra columns are f64. A line has at most 1024 columns.
//!
//! Text holds as many digits as the writer chose, so the source counts as double precision
//! when some coordinate has a finer decimal step than f32 keeps at that axis's magnitude
//! (e.g. `512345.123`: 0.001 written, 0.03 kept by f32).

use std::collections::{HashMap, HashSet};
use std::io::{BufRead, BufReader};
use std::path::Path;

use super::{Loaded, PropertyInfo, attribute, f32_step};
use crate::cloud::{Cloud, Column, Source};
use crate::error::{Error, Result};
use crate::progress::Progress;

/// Most columns a line may have: x y z and 1021 attributes. Each column becomes an attribute
/// with its name and its own array, a few hundred bytes before its first value, so without a
/// bound a 20 MB line of 10,000,000 numbers asked for gigabytes.
const MAX_COLUMNS: usize = 1024;

fn too_many_columns(path: &Path, line_no: usize) -> Error {
    Error::malformed(
        path,
        format!("line {line_no}"),
        format!(
            "more than {MAX_COLUMNS} columns: a point is x y z and at most {} attributes; is \
             this a point list with one point per line?",
            MAX_COLUMNS - 3
        ),
    )
}

fn tokens(line: &str) -> impl Iterator<Item = &str> {
    line.split(|c: char| c == ',' || c == ';' || c.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// log10 of the decimal step a number is written with: `512345.123` -> -3, `1.5e-4` -> -5.
fn decimal_exponent(tok: &str) -> i32 {
    let (mant, exp) = match tok.find(['e', 'E']) {
        Some(i) => (&tok[..i], tok[i + 1..].parse::<i32>().unwrap_or(0)),
        None => (tok, 0),
    };
    let decimals = mant.find('.').map(|i| mant.len() - i - 1).unwrap_or(0);
    exp.saturating_sub(decimals as i32)
}

/// A property name a PLY writer can carry: other characters become `_`.
fn sanitize(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if !s.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        s.insert(0, '_');
    }
    s
}

fn default_names(columns: usize, pts: bool) -> Vec<String> {
    let extra = columns.saturating_sub(3);
    let known: &[&str] = match (extra, pts) {
        (3, false) => &["nx", "ny", "nz"],
        (1, true) => &["intensity"],
        (4, true) => &["intensity", "red", "green", "blue"],
        _ => &[],
    };
    (0..extra)
        .map(|i| match known.get(i) {
            Some(n) => n.to_string(),
            None => format!("field_{}", i + 4),
        })
        .collect()
}

/// Two columns of a header line with the same name (1-based column numbers).
#[derive(Debug, PartialEq)]
struct DuplicateName {
    first: usize,
    again: usize,
    name: String,
}

/// Names from a header line, for the extra columns; unique and PLY-safe. The same name
/// twice is refused (which column would a user mean by it?); names that only become equal
/// once made PLY-safe (`a b`, `a_b`), or that would be `x`, `y`, `z` again, get `_2`, `_3`, ...
/// Hash maps keep this linear in the number of columns (a header of 20,000 equal names took
/// more than 20 s with list searches).
fn header_names(words: &[&str]) -> std::result::Result<Vec<String>, DuplicateName> {
    let mut seen: HashMap<&str, usize> = HashMap::with_capacity(words.len());
    for (i, w) in words.iter().enumerate() {
        if let Some(first) = seen.insert(w, i) {
            return Err(DuplicateName {
                first: first + 1,
                again: i + 1,
                name: w.to_string(),
            });
        }
    }
    let mut used: HashSet<String> = ["x", "y", "z"].into_iter().map(String::from).collect();
    // The next suffix to try per sanitized name, so a run of collisions is not re-scanned.
    let mut next_suffix: HashMap<String, usize> = HashMap::new();
    let mut out = Vec::with_capacity(words.len().saturating_sub(3));
    for w in words.iter().skip(3) {
        let base = sanitize(w);
        let mut name = base.clone();
        if used.contains(&name) {
            let k = next_suffix.entry(base.clone()).or_insert(2);
            loop {
                name = format!("{base}_{k}");
                *k += 1;
                if !used.contains(&name) {
                    break;
                }
            }
        }
        used.insert(name.clone());
        out.push(name);
    }
    Ok(out)
}

pub(crate) fn read(path: &Path) -> Result<Loaded> {
    let file = super::open(path)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let pts = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pts"));
    let mut reader = BufReader::with_capacity(1 << 17, file);
    let progress = if file_len >= 32 << 20 {
        Progress::start("read", file_len, "bytes")
    } else {
        Progress::hidden()
    };

    let mut names: Option<Vec<String>> = None;
    let mut ncols = 0usize;
    let mut first_data_line = 0usize;
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut extras: Vec<Vec<f64>> = Vec::new();
    let mut finest = [i32::MAX; 3];
    let mut line = String::new();
    let mut line_no = 0usize;
    let mut bytes_since_inc = 0u64;
    let mut values: Vec<f64> = Vec::new();
    loop {
        line.clear();
        let got = reader.read_line(&mut line).map_err(|e| {
            if e.kind() == std::io::ErrorKind::InvalidData {
                Error::malformed(
                    path,
                    format!("line {}", line_no + 1),
                    "not text (invalid UTF-8): is this really an XYZ text file?",
                )
            } else {
                Error::io(path, "cannot read", e)
            }
        })?;
        if got == 0 {
            break;
        }
        line_no += 1;
        bytes_since_inc += got as u64;
        if bytes_since_inc >= 1 << 22 {
            progress.inc(bytes_since_inc);
            bytes_since_inc = 0;
        }
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let is_cc_header = trimmed.starts_with("//");
        let content = trimmed.trim_start_matches('/');
        // One more than allowed tells a line that has too many (checked below, once it is
        // known whether commas separate names holding spaces).
        let words: Vec<&str> = tokens(content).take(MAX_COLUMNS + 1).collect();
        if ncols == 0 && names.is_none() {
            // Before the first point: a line of names, or a .pts point count.
            let numeric = words.iter().all(|w| w.parse::<f64>().is_ok());
            if is_cc_header || !numeric {
                // Names may hold spaces ("Scalar field") when commas separate them.
                let words: Vec<&str> = if content.contains([',', ';']) {
                    content
                        .split([',', ';'])
                        .map(str::trim)
                        .filter(|w| !w.is_empty())
                        .take(MAX_COLUMNS + 1)
                        .collect()
                } else {
                    words
                };
                if words.len() > MAX_COLUMNS {
                    return Err(too_many_columns(path, line_no));
                }
                if words.len() < 3 {
                    return Err(Error::malformed(
                        path,
                        format!("line {line_no}"),
                        format!(
                            "`{}` is neither a point (x y z ...) nor a line of column names",
                            trimmed.chars().take(80).collect::<String>()
                        ),
                    ));
                }
                let named = header_names(&words).map_err(|d| {
                    Error::malformed(
                        path,
                        format!("line {line_no}"),
                        format!(
                            "columns {} and {} of the header line are both named `{}`: which \
                             one is meant is ambiguous; rename one",
                            d.first,
                            d.again,
                            d.name.chars().take(80).collect::<String>()
                        ),
                    )
                })?;
                names = Some(named);
                ncols = words.len();
                continue;
            }
        }
        if words.len() > MAX_COLUMNS {
            return Err(too_many_columns(path, line_no));
        }
        if pts && words.len() == 1 && words[0].parse::<u64>().is_ok() {
            continue; // a Leica PTS point count line (one per scan)
        }
        values.clear();
        for (c, w) in words.iter().enumerate() {
            let v: f64 = w.parse().map_err(|_| {
                Error::malformed(
                    path,
                    format!("line {line_no}, column {}", c + 1),
                    format!("`{w}` is not a number"),
                )
            })?;
            values.push(v);
        }
        if positions.is_empty() && first_data_line == 0 {
            if values.len() < 3 {
                return Err(Error::malformed(
                    path,
                    format!("line {line_no}"),
                    format!("{} columns; a point needs at least x y z", values.len()),
                ));
            }
            if ncols != 0 && ncols != values.len() {
                return Err(Error::malformed(
                    path,
                    format!("line {line_no}"),
                    format!(
                        "{} values, but the header line names {ncols} columns",
                        values.len()
                    ),
                ));
            }
            ncols = values.len();
            first_data_line = line_no;
            extras = vec![Vec::new(); ncols - 3];
        } else if values.len() != ncols {
            return Err(Error::malformed(
                path,
                format!("line {line_no}"),
                format!(
                    "{} values, but line {first_data_line} has {ncols}: every line must have \
                     the same columns",
                    values.len()
                ),
            ));
        }
        for (k, w) in words.iter().take(3).enumerate() {
            finest[k] = finest[k].min(decimal_exponent(w));
        }
        positions.push([values[0], values[1], values[2]]);
        for (col, v) in extras.iter_mut().zip(&values[3..]) {
            col.push(*v);
        }
    }
    progress.inc(bytes_since_inc);

    let extra_names = names.unwrap_or_else(|| default_names(ncols, pts));
    let mut max_abs = [0.0f64; 3];
    for p in &positions {
        for k in 0..3 {
            if p[k].is_finite() {
                max_abs[k] = max_abs[k].max(p[k].abs());
            }
        }
    }
    let double_precision = !positions.is_empty()
        && (0..3).any(|k| 10f64.powi(finest[k].max(-400)) < f32_step(max_abs[k]));
    let attributes: Vec<_> = extra_names
        .iter()
        .zip(extras)
        .map(|(n, v)| attribute(n, Column::F64(v)))
        .collect();
    let mut properties: Vec<PropertyInfo> = ["x", "y", "z"]
        .iter()
        .map(|n| PropertyInfo {
            name: n.to_string(),
            ty: "text".into(),
        })
        .collect();
    properties.extend(attributes.iter().map(|a| PropertyInfo {
        name: a.name.clone(),
        ty: "text".into(),
    }));
    let columns = if ncols == 0 {
        "no points".to_string()
    } else {
        let all: Vec<&str> = ["x", "y", "z"]
            .into_iter()
            .chain(extra_names.iter().map(|s| s.as_str()))
            .collect();
        format!("{ncols} columns ({})", all.join(" "))
    };
    Ok(Loaded {
        cloud: Cloud {
            positions,
            attributes,
            source: Source {
                path: path.to_path_buf(),
                format: format!("XYZ text, {columns}"),
                double_precision,
            },
            structure: None,
        },
        properties,
        other_elements: Vec::new(),
        details: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_exponent_reads_the_written_step() {
        assert_eq!(decimal_exponent("512345.123"), -3);
        assert_eq!(decimal_exponent("12"), 0);
        assert_eq!(decimal_exponent("1.5e-4"), -5);
        assert_eq!(decimal_exponent("-2.25E+3"), 1);
    }

    #[test]
    fn names_are_ply_safe_and_unique() {
        assert_eq!(
            header_names(&["X", "Y", "Z", "R", "G", "B", "Scalar field", "a b", "a_b"]),
            Ok(vec!["R", "G", "B", "Scalar_field", "a_b", "a_b_2"]
                .into_iter()
                .map(String::from)
                .collect())
        );
        assert_eq!(
            header_names(&["a", "b", "c", "1st", "x"]),
            Ok(vec!["_1st".to_string(), "x_2".to_string()])
        );
        assert_eq!(
            header_names(&["X", "Y", "Z", "R", "G", "R"]),
            Err(DuplicateName {
                first: 4,
                again: 6,
                name: "R".into()
            })
        );
        assert_eq!(default_names(6, false), vec!["nx", "ny", "nz"]);
        assert_eq!(default_names(5, false), vec!["field_4", "field_5"]);
        assert_eq!(
            default_names(7, true),
            vec!["intensity", "red", "green", "blue"]
        );
    }
}
