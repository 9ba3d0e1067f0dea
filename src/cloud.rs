//! `Cloud`: the points of one scan as the pipeline sees them.
//!
//! Positions are one flat `Vec<[f64; 3]>` in file order; everything else the file carried per
//! point (colour, intensity, classification, normals, custom properties) rides along as typed
//! columns of the same length, so a writer can put it back out unchanged. Stage outputs are
//! side arrays indexed by point id; they are not stored here.

use std::path::PathBuf;

/// One typed column of per-point values. The variants are the PLY scalar types (LAS fields map
/// onto them), so a property is written back with the type it was read with.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    I8(Vec<i8>),
    U8(Vec<u8>),
    I16(Vec<i16>),
    U16(Vec<u16>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

macro_rules! each_column {
    ($col:expr, $v:ident => $body:expr) => {
        match $col {
            Column::I8($v) => $body,
            Column::U8($v) => $body,
            Column::I16($v) => $body,
            Column::U16($v) => $body,
            Column::I32($v) => $body,
            Column::U32($v) => $body,
            Column::F32($v) => $body,
            Column::F64($v) => $body,
        }
    };
}

impl Column {
    pub fn len(&self) -> usize {
        each_column!(self, v => v.len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The PLY name of the scalar type (`char`, `uchar`, … `double`).
    pub fn ply_type(&self) -> &'static str {
        match self {
            Column::I8(_) => "char",
            Column::U8(_) => "uchar",
            Column::I16(_) => "short",
            Column::U16(_) => "ushort",
            Column::I32(_) => "int",
            Column::U32(_) => "uint",
            Column::F32(_) => "float",
            Column::F64(_) => "double",
        }
    }

    /// Value `i` widened to f64 (exact for every variant).
    #[allow(clippy::useless_conversion)] // the F64 arm of the macro converts f64 to itself
    pub fn get_f64(&self, i: usize) -> f64 {
        each_column!(self, v => f64::from(v[i]))
    }

    /// Keeps the values whose `keep` flag is set, in order.
    pub fn retain_mask(&mut self, keep: &[bool]) {
        debug_assert_eq!(keep.len(), self.len());
        each_column!(self, v => {
            let mut it = keep.iter();
            v.retain(|_| *it.next().unwrap_or(&false));
        })
    }
}

/// A named per-point property carried from the input to the outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Attribute {
    pub name: String,
    pub values: Column,
}

/// Where a cloud came from and how its coordinates were stored there.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Source {
    /// The file it was read from (empty for generated clouds).
    pub path: PathBuf,
    /// Human-readable format, e.g. `PLY binary_little_endian 1.0` or `LAZ 1.2, point format 3`.
    pub format: String,
    /// True when the file stored coordinates with more precision than f32 can hold at their
    /// magnitude (double PLY, scaled LAS integers): outputs then use double coordinates.
    pub double_precision: bool,
}

/// A rigid pose: `p_cloud = rotation · p_scan + translation`, the rotation a unit quaternion
/// `[w, x, y, z]` (E57's and PCD's VIEWPOINT convention).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub rotation: [f64; 4],
    pub translation: [f64; 3],
}

impl Default for Pose {
    fn default() -> Self {
        Pose {
            rotation: [1.0, 0.0, 0.0, 0.0],
            translation: [0.0; 3],
        }
    }
}

/// One scan (setup) of the scanner: where the sensor stood and, for a structured scan, the
/// size of its grid of rows and columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scan {
    /// The scan's name in the file (E57 `name`, or the file name), for `info` and logs.
    pub name: String,
    /// The scan's pose in the cloud's coordinates; its translation is the sensor origin.
    pub pose: Pose,
    /// `[rows, columns]` of the scan's grid (an organised PCD: `[HEIGHT, WIDTH]`); `None` for
    /// an unstructured scan.
    pub grid_size: Option<[u32; 2]>,
}

/// How the scanner saw the points, where the file records it (organised PCD, E57 scans): which
/// scan each point came from, where that scan's sensor stood, and the point's row and column
/// in the scan's grid. Clouds without it (PLY, LAS, XYZ) carry `None`, and every stage works
/// without it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScanStructure {
    pub scans: Vec<Scan>,
    /// Per point: the index of its scan in `scans`.
    pub scan: Vec<u32>,
    /// Per point: `[row, column]` in its scan's grid; empty when no scan is structured.
    pub grid: Vec<[u32; 2]>,
}

impl ScanStructure {
    /// The sensor origin of point `i`.
    pub fn origin_of(&self, i: usize) -> [f64; 3] {
        self.scans[self.scan[i] as usize].pose.translation
    }

    fn retain_mask(&mut self, keep: &[bool]) {
        let mut it = keep.iter();
        self.scan.retain(|_| *it.next().unwrap_or(&false));
        if !self.grid.is_empty() {
            let mut it = keep.iter();
            self.grid.retain(|_| *it.next().unwrap_or(&false));
        }
    }

    fn is_consistent(&self, n: usize) -> bool {
        self.scan.len() == n
            && (self.grid.is_empty() || self.grid.len() == n)
            && self.scan.iter().all(|&s| (s as usize) < self.scans.len())
    }
}

/// A point cloud: positions plus carried attributes, all of the same length.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Cloud {
    pub positions: Vec<[f64; 3]>,
    pub attributes: Vec<Attribute>,
    pub source: Source,
    /// The scan structure, where the input has one.
    pub structure: Option<ScanStructure>,
}

impl Cloud {
    /// A cloud of bare positions (no attributes, no source).
    pub fn from_positions(positions: Vec<[f64; 3]>) -> Self {
        Cloud {
            positions,
            ..Default::default()
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The attribute with this name, if carried.
    pub fn attribute(&self, name: &str) -> Option<&Attribute> {
        self.attributes.iter().find(|a| a.name == name)
    }

    /// Axis-aligned bounding box `(min, max)`; `None` for an empty cloud.
    pub fn bbox(&self) -> Option<([f64; 3], [f64; 3])> {
        (!self.positions.is_empty()).then(|| crate::geometry::bounds(&self.positions))
    }

    /// The centre of the bounding box: the origin for local (f32-safe) coordinates.
    pub fn centre(&self) -> [f64; 3] {
        match self.bbox() {
            Some((lo, hi)) => [
                0.5 * (lo[0] + hi[0]),
                0.5 * (lo[1] + hi[1]),
                0.5 * (lo[2] + hi[2]),
            ],
            None => [0.0; 3],
        }
    }

    /// Keeps the points whose `keep` flag is set, positions and attributes alike.
    pub fn retain_mask(&mut self, keep: &[bool]) {
        assert_eq!(keep.len(), self.len(), "mask length must equal point count");
        let mut it = keep.iter();
        self.positions.retain(|_| *it.next().unwrap_or(&false));
        for a in &mut self.attributes {
            a.values.retain_mask(keep);
        }
        if let Some(s) = &mut self.structure {
            s.retain_mask(keep);
        }
    }

    /// Checks that every attribute has one value per point (a reader bug otherwise).
    pub fn is_consistent(&self) -> bool {
        self.attributes
            .iter()
            .all(|a| a.values.len() == self.positions.len())
            && self
                .structure
                .as_ref()
                .is_none_or(|s| s.is_consistent(self.positions.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retain_mask_keeps_positions_and_attributes_aligned() {
        let mut c = Cloud::from_positions(vec![[0.0; 3], [1.0; 3], [2.0; 3]]);
        c.attributes.push(Attribute {
            name: "intensity".into(),
            values: Column::U16(vec![10, 11, 12]),
        });
        c.structure = Some(ScanStructure {
            scans: vec![Scan::default()],
            scan: vec![0, 0, 0],
            grid: vec![[0, 0], [0, 1], [0, 2]],
        });
        c.retain_mask(&[true, false, true]);
        assert_eq!(c.positions, vec![[0.0; 3], [2.0; 3]]);
        let s = c.structure.as_ref().unwrap();
        assert_eq!((s.scan.len(), s.grid.clone()), (2, vec![[0, 0], [0, 2]]));
        assert_eq!(c.attributes[0].values, Column::U16(vec![10, 12]));
        assert!(c.is_consistent());
    }

    #[test]
    fn bbox_and_centre() {
        let c = Cloud::from_positions(vec![[1.0, -2.0, 3.0], [3.0, 2.0, -1.0]]);
        assert_eq!(c.bbox(), Some(([1.0, -2.0, -1.0], [3.0, 2.0, 3.0])));
        assert_eq!(c.centre(), [2.0, 0.0, 1.0]);
        assert_eq!(Cloud::default().bbox(), None);
    }

    #[test]
    fn column_widening_is_exact() {
        let c = Column::F32(vec![0.1]);
        assert_eq!(c.get_f64(0), f64::from(0.1f32));
        assert_eq!(Column::I8(vec![-128]).get_f64(0), -128.0);
        assert_eq!(Column::U32(vec![u32::MAX]).get_f64(0), 4294967295.0);
    }
}
