//! Candidates a run leaves out, and why: the typed record behind report.json's `left_out`
//! section and the summary line.
//!
//! Input: the reasons the edge stage (per run) and the corner stage (per vertex) give when a
//! candidate yields no edge or corner. Output: [`LeftOut`] records and their [`Tally`] by
//! reason. Most left-out candidates are judged *not a sharp edge* (a fillet, a surface
//! bending, ...): an outcome of the method, not an error. Only [`Reason::Failed`] marks a fit
//! that could not be computed, and only those are counted as failed fits.

use serde::Serialize;

/// Why a candidate gave no edge or corner. The order is the order of the summary. Serialised
/// as its [`Reason::name`], the one table of its names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Reason {
    /// The faces meet through a rounding wider than `edges.max_rounding`: a fillet.
    Fillet,
    /// The slab profiles are arcs rather than two faces: a fillet or a curved surface.
    Curved,
    /// The faces turn by less than `edges.min_turn`: a surface bending, not an edge.
    Bending,
    /// Fewer slab fits than an edge needs: too little to tell an edge from a tight bend.
    TooFewSlabs,
    /// Both sides lie on one surface (the faces fold back at a few degrees).
    OneSurface,
    /// The slab fits scatter about their course by spacings, or meet radii off the run's
    /// candidates: no one edge of theirs runs through them.
    Scattered,
    /// Too short between its vertices for any slab to keep clear of them.
    TooShort,
    /// Where the sensor's view of a surface ends (a depth jump, a face seen edge-on): a
    /// border of the scan, not an edge of the part (`stages::occlusion`).
    Occlusion,
    /// A vertex whose edges were left out (fewer than two fitted edges reach it).
    EdgesLeftOut,
    /// Where the edges meet no scan point comes near: a virtual corner of edges running into
    /// a fillet, not a corner of the part.
    VirtualCorner,
    /// The fit could not be computed (too few points, the fit did not converge, the fitted
    /// corner does not lie on its edges).
    Failed,
}

impl Reason {
    /// The name used in report.json and in the summary.
    pub fn name(self) -> &'static str {
        match self {
            Reason::Fillet => "fillet",
            Reason::Curved => "curved",
            Reason::Bending => "bending",
            Reason::TooFewSlabs => "too_few_slabs",
            Reason::OneSurface => "one_surface",
            Reason::Scattered => "scattered",
            Reason::TooShort => "too_short",
            Reason::Occlusion => "occlusion_boundary",
            Reason::EdgesLeftOut => "edges_left_out",
            Reason::VirtualCorner => "virtual_corner",
            Reason::Failed => "failed",
        }
    }
}

impl Serialize for Reason {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// What was left out: an edge candidate (a run of the segmentation) or a vertex.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Candidate {
    Run,
    Vertex,
}

/// One left-out candidate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LeftOut {
    pub kind: Candidate,
    pub reason: Reason,
    pub message: String,
}

impl LeftOut {
    pub fn vertex(reason: Reason, message: String) -> Self {
        LeftOut {
            kind: Candidate::Vertex,
            reason,
            message,
        }
    }

    pub fn is_failure(&self) -> bool {
        self.reason == Reason::Failed
    }
}

/// Left-out candidates counted by reason, in [`Reason`] order, reasons with none omitted.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally(pub Vec<(Reason, usize)>);

impl Tally {
    pub fn of(left_out: &[LeftOut]) -> Self {
        let mut counts = std::collections::BTreeMap::new();
        for l in left_out {
            *counts.entry(l.reason).or_insert(0usize) += 1;
        }
        Tally(counts.into_iter().collect())
    }

    /// Fits that could not be computed.
    pub fn failed(&self) -> usize {
        self.count(Reason::Failed)
    }

    /// Candidates left out for any reason but a failed fit.
    pub fn judged(&self) -> usize {
        self.0
            .iter()
            .filter(|(r, _)| *r != Reason::Failed)
            .map(|(_, n)| n)
            .sum()
    }

    pub fn count(&self, reason: Reason) -> usize {
        self.0
            .iter()
            .find(|(r, _)| *r == reason)
            .map_or(0, |(_, n)| *n)
    }

    /// "left out 166 candidates (fillet 120, bending 46), 5 fits failed" for the summary.
    pub fn summary(&self) -> String {
        let judged: Vec<String> = self
            .0
            .iter()
            .filter(|(r, _)| *r != Reason::Failed)
            .map(|(r, n)| format!("{} {n}", r.name().replace('_', " ")))
            .collect();
        let n = self.judged();
        let mut t = format!("left out {n} candidate{}", if n == 1 { "" } else { "s" });
        if !judged.is_empty() {
            t += &format!(" ({})", judged.join(", "));
        }
        let f = self.failed();
        t + &format!(", {f} fit{} failed", if f == 1 { "" } else { "s" })
    }
}

impl Serialize for Tally {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (r, n) in &self.0 {
            m.serialize_entry(r.name(), n)?;
        }
        m.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(reason: Reason) -> LeftOut {
        LeftOut {
            kind: Candidate::Run,
            reason,
            message: String::new(),
        }
    }

    #[test]
    fn tally_counts_by_reason_and_keeps_failed_apart() {
        let all = [
            run(Reason::Bending),
            run(Reason::Fillet),
            run(Reason::Failed),
            run(Reason::Fillet),
            LeftOut::vertex(Reason::VirtualCorner, "corner 3".into()),
        ];
        let t = Tally::of(&all);
        assert_eq!(
            t.0,
            vec![
                (Reason::Fillet, 2),
                (Reason::Bending, 1),
                (Reason::VirtualCorner, 1),
                (Reason::Failed, 1)
            ]
        );
        assert_eq!((t.judged(), t.failed()), (4, 1));
        assert_eq!(
            t.summary(),
            "left out 4 candidates (fillet 2, bending 1, virtual corner 1), 1 fit failed"
        );
        assert_eq!(
            serde_json::to_string(&t).unwrap(),
            r#"{"fillet":2,"bending":1,"virtual_corner":1,"failed":1}"#
        );
        assert_eq!(
            Tally::of(&[]).summary(),
            "left out 0 candidates, 0 fits failed"
        );
    }
}
