//! The face-based topology of an OpenFOAM polyMesh, kept beside the cells
//! read from it so that writing the mesh back as a polyMesh changes nothing
//! but the points: the same faces in the same order, the same owners and
//! neighbours, the `boundary` and zone files as they were.

use std::path::PathBuf;

/// How the input's files were encoded, so that the output keeps it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FoamStyle {
    /// `format binary;` in the header of `points`.
    pub binary: bool,
    /// The files were gzip-compressed (`points.gz`).
    pub compressed: bool,
    /// Labels of 64 bits (`arch "...;label=64"`), else 32.
    pub label64: bool,
    /// Scalars of 32 bits (`arch "...;scalar=32"`), else 64.
    pub scalar32: bool,
    /// `faces` was a `faceCompactList` (offsets and labels) rather than a
    /// `faceList`.
    pub compact_faces: bool,
}

/// One `boundary` entry: a run of boundary faces.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Patch {
    /// The patch name.
    pub name: String,
    /// Its `type` (`wall`, `patch`, `empty`, `symmetryPlane`, ...).
    pub kind: String,
    /// Its first face.
    pub start: usize,
    /// How many faces it has.
    pub faces: usize,
}

/// A polyMesh file kept byte for byte (decompressed): `boundary`,
/// `cellZones`, `faceZones`, `pointZones`.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FoamFileCopy {
    /// The file name without `.gz`.
    pub name: String,
    /// Whether it was gzip-compressed.
    pub compressed: bool,
    /// Its content.
    pub bytes: Vec<u8>,
}

/// Everything of a polyMesh but its points.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PolyMesh {
    /// Per face, the offset of its first point in `face_points` (faces + 1 entries).
    pub face_offsets: Vec<usize>,
    /// The faces' point ids, concatenated.
    pub face_points: Vec<u32>,
    /// Per face, the cell its normal points out of.
    pub owner: Vec<u32>,
    /// Per internal face (the first ones), the other cell.
    pub neighbour: Vec<u32>,
    /// The boundary patches, in the order of their faces.
    pub patches: Vec<Patch>,
    /// `boundary` and the zone files, as read.
    pub files: Vec<FoamFileCopy>,
    /// How the input was encoded.
    pub style: FoamStyle,
    /// The `constant/polyMesh` folder it was read from (canonical), which
    /// a write must not replace; its other files (`sets/`, `cellLevel`)
    /// are copied to the output.
    pub source: Option<PathBuf>,
    /// Per patch, the range of `Mesh::lower` its faces became (a polygon
    /// is split into triangles).
    pub lower: Vec<std::ops::Range<usize>>,
}

impl PolyMesh {
    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.face_offsets.len().saturating_sub(1)
    }

    /// Face `f`'s point ids.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.face_points[self.face_offsets[f]..self.face_offsets[f + 1]]
    }

    /// Number of cells: one past the largest owner or neighbour.
    pub fn num_cells(&self) -> usize {
        self.owner
            .iter()
            .chain(&self.neighbour)
            .max()
            .map_or(0, |&c| c as usize + 1)
    }

    /// Per lower cell (of `lower` in all), whether it lies on a patch of
    /// type `wall`: those keep their vertices when the boundary slides.
    pub fn wall_lower_cells(&self, lower: usize) -> Vec<bool> {
        let mut out = vec![false; lower];
        for (p, range) in self.patches.iter().zip(&self.lower) {
            if p.kind == "wall" {
                out.iter_mut().take(range.end).skip(range.start).for_each(|w| *w = true);
            }
        }
        out
    }
}
