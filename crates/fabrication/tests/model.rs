//! 3D models: the glTF is read back and validated by the `gltf` crate, positions are the
//! folded pattern's (to f32 precision, 1e-6 relative), colours mark modules and strain.

use fabrication::folded::{fold, LayerState};
use fabrication::model::{face_colour, validate_glb, Model, PALETTE};
use fabrication::pattern::Pattern;
use fabrication::{Module, Trunk};
use geometry::{ModuleDesign, ShapeState};

fn pattern(betas: &[(f64, usize)]) -> Pattern {
    let modules = betas
        .iter()
        .map(|&(b, layers)| Module {
            design: ModuleDesign::new(3, b).unwrap(),
            layers,
        })
        .collect();
    Pattern::new(&Trunk::new(modules, 75.0).unwrap(), 0.0).unwrap()
}

fn is_red(c: [f32; 4]) -> bool {
    c[0] > 0.8 && c[1] < 0.2 && c[2] < 0.2
}

#[test]
fn the_gltf_of_the_deployed_crane_validates_and_holds_every_face() {
    let p = pattern(&[(35.0, 2), (31.72, 2)]);
    let f = fold(&p, &[LayerState::Shape(ShapeState::Deployed); 4]).unwrap();
    let model = Model::new(&p, &f);
    let bytes = model.glb("test").unwrap();
    assert_eq!(validate_glb(&bytes).unwrap(), p.faces.len());
    // Read the positions back and compare with the folded coordinates (metres, +Y up).
    let g = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = g.blob.as_deref();
    let prim = g.meshes().next().unwrap().primitives().next().unwrap();
    let reader = prim.reader(|_| blob);
    let pos: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    for (k, face) in p.faces.iter().enumerate() {
        for (c, &v) in face.v.iter().enumerate() {
            let q = f.coords[v] * 75.0 / 1000.0;
            let r = pos[3 * k + c];
            let want = [q.x, q.z, -q.y];
            for i in 0..3 {
                assert!((r[i] as f64 - want[i]).abs() < 1e-6, "{r:?} vs {want:?}");
            }
        }
    }
    // Two modules, two colours, nothing strained.
    let c0 = PALETTE[0].map(|c| c as f32 / 255.0);
    let c1 = PALETTE[1].map(|c| c as f32 / 255.0);
    for (f, c) in p.faces.iter().zip(&model.mesh.colours) {
        let want = if f.module == 0 { c0 } else { c1 };
        assert!((0..3).all(|i| (c[i] - want[i]).abs() < 1e-6));
    }
    // The deployed trunk's height: Σ w l = 197.745 mm (glTF y, metres).
    let top = pos.iter().map(|p| p[1]).fold(f32::MIN, f32::max) as f64;
    assert!((top - 0.150 * (35f64.to_radians().tan() + 31.72f64.to_radians().tan())).abs() < 1e-6);
}

#[test]
fn strained_states_are_drawn_red_and_exact_ones_are_not() {
    let p = pattern(&[(35.0, 3)]);
    let f = fold(&p, &[LayerState::Shape(ShapeState::Edge(0)); 3]).unwrap();
    let m = Model::new(&p, &f);
    assert!(!m.feasible && m.max_strain > 0.05);
    assert!(m.mesh.colours.iter().any(|c| is_red(*c)));
    assert!(validate_glb(&m.glb("t").unwrap()).is_ok());
    let golden = pattern(&[(31.717_474_411_461_005, 3)]);
    let f = fold(&golden, &[LayerState::Shape(ShapeState::Edge(0)); 3]).unwrap();
    let m = Model::new(&golden, &f);
    assert!(m.max_strain < 1e-9 && !m.mesh.colours.iter().any(|c| is_red(*c)));
    assert_eq!(face_colour(0, 1.0), [0.9, 0.05, 0.05]);
    assert_eq!(face_colour(8, 0.0), face_colour(0, 0.0));
}

#[test]
fn the_obj_has_a_coloured_vertex_per_corner_and_a_face_per_triangle() {
    let p = pattern(&[(35.0, 1)]);
    let f = fold(&p, &[LayerState::SelfPacked]).unwrap();
    let m = Model::new(&p, &f);
    let obj = m.obj();
    let v = obj.lines().filter(|l| l.starts_with("v ")).count();
    let faces = obj.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!((v, faces), (3 * p.faces.len(), p.faces.len()));
    assert!(obj
        .lines()
        .filter(|l| l.starts_with("v "))
        .all(|l| l.split(' ').count() == 7));
    let mut stl = Vec::new();
    m.mesh.write_stl(&mut stl).unwrap();
    assert_eq!(stl.len(), 84 + 50 * p.faces.len());
}

#[test]
fn a_corrupt_glb_is_refused_by_the_reader() {
    let p = pattern(&[(35.0, 1)]);
    let f = fold(&p, &[LayerState::Shape(ShapeState::Folded)]).unwrap();
    let mut bytes = Model::new(&p, &f).glb("t").unwrap();
    assert!(validate_glb(&bytes[..bytes.len() / 2]).is_err());
    bytes[0] = b'x';
    assert!(validate_glb(&bytes).is_err());
}
