//! Edges and corners as GeoJSON, for GIS programs (QGIS, GDAL/OGR) to show beside the points.
//!
//! Input: features (a 3D line string per edge, a 3D point per corner, with their properties)
//! and the cloud's CRS. Output: one FeatureCollection written atomically. Coordinates are the
//! cloud's own (RFC 7946 asks for WGS84 longitude/latitude, which a scan in a projected CRS is
//! not): the `"crs"` member of GeoJSON 2008 names the CRS, which GDAL reads (an OGC URN or
//! WKT text). A cloud without a CRS gets a `LOCAL_CS`, so GDAL reports an engineering CRS
//! instead of assuming WGS84.

use std::path::Path;

use serde::Serialize;
use serde_json::{Map, Value, json};

use super::Crs;
use crate::error::{Error, Result};

/// A feature's geometry, in the cloud's coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    Point([f64; 3]),
    LineString(Vec<[f64; 3]>),
}

/// One GeoJSON feature.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoFeature {
    pub geometry: Geometry,
    pub properties: Map<String, Value>,
}

/// The CRS name written when the cloud has none.
pub const NO_CRS: &str = "LOCAL_CS[\"sharpedge: the input declares no CRS\"]";

/// Writes `features` as a GeoJSON FeatureCollection in `crs` (see the module comment).
pub fn write_geojson(path: &Path, features: &[GeoFeature], crs: Option<&Crs>) -> Result<()> {
    // Structs, not `json!`, so the members come in GeoJSON's customary order ("type" first).
    #[derive(Serialize)]
    struct Collection<'a> {
        #[serde(rename = "type")]
        ty: &'static str,
        name: &'static str,
        crs: Value,
        features: Vec<Feature<'a>>,
    }
    #[derive(Serialize)]
    struct Feature<'a> {
        #[serde(rename = "type")]
        ty: &'static str,
        properties: &'a Map<String, Value>,
        geometry: Value,
    }
    let mut list = Vec::with_capacity(features.len());
    for (k, f) in features.iter().enumerate() {
        let points: &[[f64; 3]] = match &f.geometry {
            Geometry::Point(p) => std::slice::from_ref(p),
            Geometry::LineString(l) => l,
        };
        if let Some(p) = points.iter().find(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(Error::BadOutput {
                path: path.to_path_buf(),
                what: format!(
                    "feature {k} has a non-finite coordinate ({}, {}, {})",
                    p[0], p[1], p[2]
                ),
            });
        }
        let geometry = match &f.geometry {
            Geometry::Point(p) => json!({"type": "Point", "coordinates": p}),
            Geometry::LineString(l) => json!({"type": "LineString", "coordinates": l}),
        };
        list.push(Feature {
            ty: "Feature",
            properties: &f.properties,
            geometry,
        });
    }
    let name = crs.map_or_else(|| NO_CRS.to_string(), Crs::geojson_name);
    let doc = Collection {
        ty: "FeatureCollection",
        name: "edges",
        crs: json!({"type": "name", "properties": {"name": name}}),
        features: list,
    };
    let text = crate::json::pretty(&doc)
        .map_err(|e| Error::io(path, "cannot write GeoJSON", e.into()))?
        + "\n";
    super::write_atomic(path, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| Error::io(path, "cannot write GeoJSON", e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collection_with_crs_and_z_coordinates() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("edges.geojson");
        let mut props = Map::new();
        props.insert("id".into(), json!(3));
        let features = [
            GeoFeature {
                geometry: Geometry::LineString(vec![[637000.5, 851000.25, 420.0], [1.0, 2.0, 3.0]]),
                properties: props.clone(),
            },
            GeoFeature {
                geometry: Geometry::Point([0.1, 0.2, 0.3]),
                properties: props,
            },
        ];
        write_geojson(&path, &features, Some(&Crs::Epsg(2903))).unwrap();
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(v["crs"]["properties"]["name"], "urn:ogc:def:crs:EPSG::2903");
        assert_eq!(v["features"][0]["geometry"]["type"], "LineString");
        assert_eq!(
            v["features"][0]["geometry"]["coordinates"][0],
            json!([637000.5, 851000.25, 420.0])
        );
        assert_eq!(
            v["features"][1]["geometry"]["coordinates"],
            json!([0.1, 0.2, 0.3])
        );
        assert_eq!(v["features"][1]["properties"]["id"], 3);
        write_geojson(&path, &features, None).unwrap();
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(v["crs"]["properties"]["name"], NO_CRS);
        let bad = [GeoFeature {
            geometry: Geometry::Point([f64::NAN, 0.0, 0.0]),
            properties: Map::new(),
        }];
        let e = write_geojson(&path, &bad, None).unwrap_err().to_string();
        assert!(e.contains("feature 0 has a non-finite coordinate"), "{e}");
    }
}
