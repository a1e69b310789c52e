//! FOLD v1.2: the flat crease pattern plus one frame per requested state.
//!
//! The key frame is the crease pattern (`vertices_coords` in mm, 2D; `edges_vertices`,
//! `edges_assignment` M/V/B/U — U for the virtual creases —, `faces_vertices`,
//! `edges_foldAngle` = the first state's angles, the target Origami Simulator folds towards).
//! Each state is a `file_frames` entry (`frame_parent` 0, `frame_inherit` true) with the folded
//! 3D `vertices_coords` (mm) and its own `edges_foldAngle` and `edges_assignment` (M/V where
//! the edge folds, F where it stays flat, B on the boundary). Custom properties use the
//! `yoshimura:` namespace: the layer states and the measured strain.

use serde_json::{json, Value};

use crate::folded::{fold_angles, Folded};
use crate::pattern::{LineKind, Pattern};

/// Fold angles below this (degrees) are written as flat (`F`) in a frame's assignment.
pub const FLAT_DEG: f64 = 1e-6;

fn round(x: f64) -> f64 {
    // 1e-9 mm resolution keeps files small and exact to far below any tolerance.
    let r = (x * 1e9).round() / 1e9;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// Builds the FOLD object. `frames` are (title, folded configuration) pairs.
pub fn document(pattern: &Pattern, frames: &[(String, Folded)], creator: &str) -> Value {
    let l = pattern.trunk().edge_mm();
    let vertices: Vec<Value> = pattern
        .vertices
        .iter()
        .map(|v| json!([round(v[0] * l), round(v[1] * l)]))
        .collect();
    let edges: Vec<Value> = pattern.edges.iter().map(|e| json!(e.v)).collect();
    let assignment: Vec<&str> = pattern
        .edges
        .iter()
        .map(|e| e.kind.fold_assignment())
        .collect();
    let faces: Vec<Value> = pattern.faces.iter().map(|f| json!(f.v)).collect();
    let angles: Vec<Vec<f64>> = frames
        .iter()
        .map(|(_, f)| fold_angles(pattern, f).into_iter().map(round).collect())
        .collect();
    let key_angles: Vec<f64> = angles
        .first()
        .cloned()
        .unwrap_or_else(|| vec![0.0; pattern.edges.len()]);
    let file_frames: Vec<Value> = frames
        .iter()
        .zip(&angles)
        .map(|((title, f), a)| {
            let coords: Vec<Value> = f
                .coords
                .iter()
                .map(|p| json!([round(p.x * l), round(p.y * l), round(p.z * l)]))
                .collect();
            let assign: Vec<&str> = pattern
                .edges
                .iter()
                .zip(a)
                .map(|(e, &ang)| {
                    if matches!(e.kind, LineKind::Boundary | LineKind::Cut) {
                        "B"
                    } else if ang.abs() <= FLAT_DEG {
                        "F"
                    } else if ang < 0.0 {
                        "M"
                    } else {
                        "V"
                    }
                })
                .collect();
            let states: Vec<String> = f.states.iter().map(|s| s.to_string()).collect();
            json!({
                "frame_title": title,
                "frame_classes": ["foldedForm"],
                "frame_attributes": ["3D", "manifold", "orientable"],
                "frame_unit": "mm",
                "frame_parent": 0,
                "frame_inherit": true,
                "vertices_coords": coords,
                "edges_foldAngle": a,
                "edges_assignment": assign,
                "yoshimura:layer_states": states,
                "yoshimura:states_feasible": f.feasible,
                "yoshimura:max_strain": f.max_strain,
            })
        })
        .collect();
    // Rows (y, mm) where two modules meet: β changes there, so Kawasaki's theorem fails at
    // their interior vertices by 2(β_above − β_below) (checked by tools/fabrication).
    let mut interfaces = Vec::new();
    let layers = pattern.layers();
    for k in 1..layers.len() {
        if layers[k].0 != layers[k - 1].0 && layers[k].1.beta_deg() != layers[k - 1].1.beta_deg() {
            interfaces.push(round(pattern.row_y(k) * l));
        }
    }
    json!({
        "file_spec": 1.2,
        "file_creator": creator,
        "file_title": format!("Yoshimura trunk crease pattern: {}", pattern.trunk().describe()),
        "file_classes": ["singleModel"],
        "frame_title": "crease pattern",
        "frame_classes": ["creasePattern"],
        "frame_attributes": ["2D", "manifold", "orientable"],
        "frame_unit": "mm",
        "vertices_coords": vertices,
        "edges_vertices": edges,
        "edges_assignment": assignment,
        "edges_foldAngle": key_angles,
        "faces_vertices": faces,
        "file_frames": file_frames,
        "yoshimura:module_interface_y_mm": interfaces,
    })
}
