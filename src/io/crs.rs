//! The coordinate reference system of a LAS/LAZ file, for the GeoJSON written beside it.
//!
//! Input: the file's VLRs and EVLRs. Output: a [`Crs`]: the WKT of the `LASF_Projection` 2112
//! record (authoritative when present, LAS 1.4 R15 §2.5), else the EPSG code of the GeoTIFF
//! keys (`ProjectedCSTypeGeoKey` 3072, else `GeographicTypeGeoKey` 2048). GDAL's GeoJSON
//! driver, and so QGIS, reads a `"crs"` member named by an OGC URN
//! (`urn:ogc:def:crs:EPSG::2903`) or by WKT text; [`Crs::geojson_name`] gives the URN when
//! the WKT's outermost node has an EPSG authority, the WKT otherwise (checked with `ogrinfo`
//! 3.6 by scripts/check_lidar.sh).

/// A coordinate reference system as a file declares it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Crs {
    /// An EPSG code (from GeoTIFF keys).
    Epsg(u32),
    /// OGC WKT text (from the WKT VLR).
    Wkt(String),
}

impl Crs {
    /// The name for a GeoJSON `"crs": {"type": "name", ...}` member.
    pub fn geojson_name(&self) -> String {
        let urn = |code: u32| format!("urn:ogc:def:crs:EPSG::{code}");
        match self {
            Crs::Epsg(code) => urn(*code),
            Crs::Wkt(wkt) => match outer_epsg(wkt) {
                Some(code) => urn(code),
                None => wkt.clone(),
            },
        }
    }
}

const PROJECTION: &str = "LASF_Projection";
const WKT_RECORD: u16 = 2112;
const GEOKEYS_RECORD: u16 = 34735;
/// GeoTIFF's code for "user-defined": no EPSG code to name.
const USER_DEFINED: u16 = 32767;

/// The CRS declared by these VLRs: WKT first, then GeoTIFF keys.
pub(super) fn of_vlrs<'a>(vlrs: impl Iterator<Item = &'a las::Vlr> + Clone) -> Option<Crs> {
    let wkt = vlrs
        .clone()
        .find(|v| v.user_id == PROJECTION && v.record_id == WKT_RECORD)
        .map(|v| {
            let end = v.data.iter().position(|&b| b == 0).unwrap_or(v.data.len());
            String::from_utf8_lossy(&v.data[..end]).trim().to_string()
        })
        .filter(|w| !w.is_empty());
    if let Some(w) = wkt {
        return Some(Crs::Wkt(w));
    }
    vlrs.into_iter()
        .find(|v| v.user_id == PROJECTION && v.record_id == GEOKEYS_RECORD)
        .and_then(|v| geokey_epsg(&v.data))
        .map(Crs::Epsg)
}

/// The EPSG code of a GeoKeyDirectoryTag: the projected CRS key, else the geographic one;
/// `None` when neither holds a code inline or the code is user-defined.
fn geokey_epsg(data: &[u8]) -> Option<u32> {
    let words: Vec<u16> = data
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    let count = usize::from(*words.get(3)?);
    let key = |id: u16| {
        (0..count).find_map(|k| {
            let e = words.get(4 + 4 * k..8 + 4 * k)?;
            // Location 0: the value is the fourth word itself.
            (e[0] == id && e[1] == 0 && e[3] != USER_DEFINED && e[3] != 0).then_some(e[3])
        })
    };
    key(3072).or_else(|| key(2048)).map(u32::from)
}

/// The EPSG code in the authority (`AUTHORITY["EPSG","2903"]`, WKT2 `ID["EPSG",2903]`) of the
/// outermost node of a WKT, if it has one: a nested node's authority names a part (datum,
/// unit), not the whole.
fn outer_epsg(wkt: &str) -> Option<u32> {
    let b = wkt.as_bytes();
    let mut depth = 0usize;
    let mut in_string = false;
    let mut found = None;
    for (i, &c) in b.iter().enumerate() {
        match c {
            b'"' => in_string = !in_string,
            _ if in_string => {}
            b'[' | b'(' => {
                // A node opening at depth 1 is a direct child of the outermost node.
                if depth == 1 {
                    let name_start = wkt[..i].rfind([',', '[', '(']).map_or(0, |p| p + 1);
                    let name = wkt[name_start..i].trim().to_ascii_uppercase();
                    if name == "AUTHORITY" || name == "ID" {
                        found = epsg_args(&wkt[i + 1..]);
                    }
                }
                depth += 1;
            }
            b']' | b')' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    found
}

/// `"EPSG","2903"]...` or `"EPSG",2903]...` → 2903.
fn epsg_args(s: &str) -> Option<u32> {
    let end = s.find([']', ')'])?;
    let mut parts = s[..end].split(',').map(|p| p.trim().trim_matches('"'));
    if !parts.next()?.eq_ignore_ascii_case("EPSG") {
        return None;
    }
    parts.next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vlr(record_id: u16, data: Vec<u8>) -> las::Vlr {
        las::Vlr {
            user_id: PROJECTION.into(),
            record_id,
            description: String::new(),
            data,
        }
    }

    #[test]
    fn outermost_authority_only() {
        let wkt = r#"PROJCS["NAD83(HARN) / New Mexico Central (ftUS)",GEOGCS["NAD83(HARN)",AUTHORITY["EPSG","4152"]],UNIT["US survey foot",0.3048006096012192,AUTHORITY["EPSG","9003"]],AUTHORITY["EPSG","2903"],VERTCS["NAVD88",AUTHORITY["EPSG","5703"]]]"#;
        assert_eq!(outer_epsg(wkt), Some(2903));
        assert_eq!(
            Crs::Wkt(wkt.into()).geojson_name(),
            "urn:ogc:def:crs:EPSG::2903"
        );
        // autzen's WKT: a custom projection, only its parts have codes.
        let custom = r#"PROJCS["NAD_1983_HARN_Lambert_Conformal_Conic",GEOGCS["GCS",DATUM["D",SPHEROID["GRS_1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],AUTHORITY["EPSG","6152"]]],UNIT["foot",0.3048,AUTHORITY["EPSG","9002"]]]"#;
        assert_eq!(outer_epsg(custom), None);
        assert_eq!(Crs::Wkt(custom.into()).geojson_name(), custom);
        assert_eq!(outer_epsg(r#"PROJCRS["x",ID["EPSG",32633]]"#), Some(32633));
        assert_eq!(
            outer_epsg(r#"PROJCS["a,[b]",AUTHORITY["ESRI","102003"]]"#),
            None
        );
    }

    #[test]
    fn wkt_before_geotiff_and_geotiff_codes() {
        // Directory header (1, 1, 0, 2 keys), then GTModelType = 1 and ProjectedCSType = 2994.
        let keys: Vec<u8> = [1u16, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, 2994]
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect();
        let geo = vlr(GEOKEYS_RECORD, keys.clone());
        assert_eq!(of_vlrs([&geo].into_iter()), Some(Crs::Epsg(2994)));
        let wkt = vlr(WKT_RECORD, b"GEOGCS[\"WGS 84\"]\0\0".to_vec());
        assert_eq!(
            of_vlrs([&geo, &wkt].into_iter()),
            Some(Crs::Wkt("GEOGCS[\"WGS 84\"]".into()))
        );
        // User-defined projection: no code.
        let mut user = keys;
        user[22..24].copy_from_slice(&USER_DEFINED.to_le_bytes());
        assert_eq!(of_vlrs([&vlr(GEOKEYS_RECORD, user)].into_iter()), None);
        assert_eq!(of_vlrs([].into_iter()), None);
    }
}
