//! The trunk's 3D shape as Foxglove scene messages (`foxglove.SceneUpdate`,
//! `foxglove.FrameTransforms`), from what the device reports: the modules in their current
//! states (the folded pattern of `fabrication::folded`, built by the geometry crate), the bend
//! from the three tendons (servo angles → tendon length changes → a constant-curvature bend,
//! `geometry::tendon`), and the pressure as colour.
//!
//! One place builds them; the recording and the live view both carry what [`Scene::build`]
//! returns. Units: metres, +Z up along the trunk, frame `base` at the bottom ring's centre;
//! tendon 0 lies along +X (its servo pulls the trunk toward +X).

use std::collections::HashMap;

use fabrication::folded::{fold, LayerState};
use fabrication::pattern::Pattern;
use fabrication::{Module, Trunk};
use foxglove::messages::{
    Color, CubePrimitive, FrameTransform, FrameTransforms, Point3, Pose, Quaternion, SceneEntity,
    SceneUpdate, SpherePrimitive, TextPrimitive, Timestamp, TriangleListPrimitive, Vector3,
};
use geometry::tendon::{Bend, TendonGeometry};
use geometry::{BottomState, ModuleDesign, TopState, TrunkState};
use protocol::CraneGeometry;

/// The frame the trunk is drawn in.
pub const BASE_FRAME: &str = "base";
/// The frame at the trunk's tip (its top ring's centre, +Z along the tip's axis).
pub const TIP_FRAME: &str = "tip";

/// One module's mesh: vertices (mm, base frame, straight trunk) and triangle indices.
#[derive(Debug, Clone)]
struct ModuleMesh {
    points: Vec<[f64; 3]>,
    indices: Vec<u32>,
}

/// What the scene shows, from one telemetry sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The device's state.
    pub state: TrunkState,
    /// Whether the device has confirmed it.
    pub confirmed: bool,
    /// Servo angles, degrees.
    pub servo_deg: [f32; 3],
    /// Pressure, kPa.
    pub pressure_kpa: f32,
}

/// Builds the scene of the crane's trunk; folded meshes are kept per state.
#[derive(Debug)]
pub struct Scene {
    pattern: Pattern,
    designs: Vec<(TrunkLayer, ModuleDesign)>,
    meshes: HashMap<TrunkState, Vec<ModuleMesh>>,
    cfg: CraneGeometry,
    pressure_limit_kpa: f32,
    tendons: TendonGeometry,
}

/// Which module a layer of the pattern belongs to.
#[derive(Debug, Clone, Copy)]
enum TrunkLayer {
    Bottom,
    Top,
}

impl Scene {
    /// The scene of the trunk the device reports in its handshake (modules, layers, edge
    /// length, pressure cap); the servo winches and the tendon radius are the crane's as built
    /// ([`CraneGeometry::default`]: the device does not report them).
    pub fn new(trunk: &protocol::TrunkConfig) -> anyhow::Result<Self> {
        let cfg = CraneGeometry::default().with_trunk(trunk);
        let trunk_cap = trunk.pressure_limit_kpa;
        let module = |m: &protocol::ModuleConfig| -> anyhow::Result<Module> {
            let design = ModuleDesign::new(u32::from(m.n), f64::from(m.beta_deg))
                .map_err(|e| anyhow::anyhow!("the trunk's module design: {e:?}"))?;
            Ok(Module {
                design,
                layers: usize::from(m.layers),
            })
        };
        let (bottom, top) = (module(&trunk.bottom)?, module(&trunk.top)?);
        let trunk = Trunk::new(vec![bottom, top], f64::from(trunk.bottom.edge_mm))
            .map_err(|e| anyhow::anyhow!("the trunk: {e}"))?;
        let pattern = Pattern::new(&trunk, 0.0).map_err(|e| anyhow::anyhow!("{e}"))?;
        let designs = pattern
            .layers()
            .iter()
            .map(|&(m, d)| {
                (
                    if m == 0 {
                        TrunkLayer::Bottom
                    } else {
                        TrunkLayer::Top
                    },
                    d,
                )
            })
            .collect();
        let tendons = TendonGeometry::new(f64::from(cfg.tendon_radius_mm))
            .map_err(|e| anyhow::anyhow!("the tendons: {e}"))?;
        Ok(Self {
            pattern,
            designs,
            meshes: HashMap::new(),
            cfg,
            pressure_limit_kpa: trunk_cap,
            tendons,
        })
    }

    /// The scene of the firmware's default trunk (the paper's crane).
    #[cfg(test)]
    pub fn crane() -> anyhow::Result<Self> {
        // 40 kPa: the firmware's default cap.
        Self::new(&CraneGeometry::default().trunk(40.0))
    }

    /// Number of modules (one scene entity each).
    pub fn module_count(&self) -> usize {
        self.pattern.trunk().modules().len()
    }

    /// The pressure cap the colour scale ends at, kPa.
    pub fn pressure_limit_kpa(&self) -> f32 {
        self.pressure_limit_kpa
    }

    /// The bend the servo angles make (their common part is an axial pull, not a bend).
    pub fn bend(&self, servo_deg: [f32; 3]) -> Bend {
        let dl = [0, 1, 2].map(|i| -f64::from(self.cfg.winch.length_for_angle(i, servo_deg[i])));
        self.tendons
            .bend_from_length_changes(dl)
            .map_or(Bend::STRAIGHT, |s| s.bend)
    }

    fn meshes(&mut self, state: TrunkState) -> anyhow::Result<&[ModuleMesh]> {
        if !self.meshes.contains_key(&state) {
            let states = self
                .designs
                .iter()
                .map(|(which, d)| {
                    let name = match which {
                        TrunkLayer::Bottom => match state.bottom {
                            BottomState::Packed => "self-packed",
                            BottomState::Folded => "folded",
                            BottomState::Deployed => "deployed",
                        },
                        TrunkLayer::Top => match state.top {
                            TopState::Folded => "folded",
                            TopState::Deployed => "deployed",
                        },
                    };
                    LayerState::parse(d, name).map_err(|e| anyhow::anyhow!("{state}: {e}"))
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            let folded = fold(&self.pattern, &states).map_err(|e| anyhow::anyhow!("{e}"))?;
            let l = self.pattern.trunk().edge_mm();
            let mut meshes: Vec<ModuleMesh> = (0..self.module_count())
                .map(|_| ModuleMesh {
                    points: Vec::new(),
                    indices: Vec::new(),
                })
                .collect();
            let mut local: Vec<HashMap<usize, u32>> = vec![HashMap::new(); meshes.len()];
            for f in &self.pattern.faces {
                let m = &mut meshes[f.module];
                for v in f.v {
                    let i = *local[f.module].entry(v).or_insert_with(|| {
                        let q = folded.coords[v];
                        m.points.push([q.x * l, q.y * l, q.z * l]);
                        (m.points.len() - 1) as u32
                    });
                    m.indices.push(i);
                }
            }
            self.meshes.insert(state, meshes);
        }
        Ok(&self.meshes[&state])
    }

    /// The scene and the tip's transform for `s` at `log_time_ns` (the message's log time).
    pub fn build(
        &mut self,
        s: &Sample,
        log_time_ns: u64,
    ) -> anyhow::Result<(SceneUpdate, FrameTransforms)> {
        let bend = self.bend(s.servo_deg);
        let limit = self.pressure_limit_kpa();
        let colour = pressure_colour(s.pressure_kpa, limit, s.confirmed);
        let stamp = Timestamp::new(
            (log_time_ns / 1_000_000_000) as u32,
            (log_time_ns % 1_000_000_000) as u32,
        );
        let meshes = self.meshes(s.state)?.to_vec();
        let height_mm = meshes
            .iter()
            .flat_map(|m| m.points.iter())
            .map(|p| p[2])
            .fold(0.0, f64::max)
            .max(1.0);
        let arc = Arc::new(bend, height_mm);
        let mut entities = Vec::with_capacity(meshes.len());
        for (k, m) in meshes.iter().enumerate() {
            let shade = 1.0 - 0.18 * k as f32;
            let points = m
                .points
                .iter()
                .map(|&p| {
                    let q = arc.map(p);
                    Point3 {
                        x: q[0] / 1000.0,
                        y: q[1] / 1000.0,
                        z: q[2] / 1000.0,
                    }
                })
                .collect();
            let mut texts = Vec::new();
            if k + 1 == meshes.len() {
                let (tip, _) = arc.tip();
                texts.push(TextPrimitive {
                    pose: Some(Pose {
                        position: Some(Vector3 {
                            x: tip[0] / 1000.0,
                            y: tip[1] / 1000.0,
                            z: tip[2] / 1000.0 + 0.04,
                        }),
                        orientation: Some(identity()),
                    }),
                    billboard: true,
                    font_size: 14.0,
                    scale_invariant: true,
                    color: Some(Color {
                        r: 1.0,
                        g: 1.0,
                        b: 1.0,
                        a: 1.0,
                    }),
                    text: format!(
                        "{}{} · {:.1} kPa · bend {:.1}°",
                        s.state,
                        if s.confirmed { "" } else { " (unconfirmed)" },
                        s.pressure_kpa,
                        bend.angle.to_degrees()
                    ),
                });
            }
            entities.push(SceneEntity {
                timestamp: Some(stamp),
                frame_id: BASE_FRAME.into(),
                id: format!("module-{k}"),
                frame_locked: false,
                triangles: vec![TriangleListPrimitive {
                    pose: Some(Pose {
                        position: Some(Vector3::default()),
                        orientation: Some(identity()),
                    }),
                    points,
                    color: Some(Color {
                        r: f64::from(colour[0] * shade),
                        g: f64::from(colour[1] * shade),
                        b: f64::from(colour[2] * shade),
                        a: f64::from(colour[3]),
                    }),
                    colors: Vec::new(),
                    indices: m.indices.clone(),
                }],
                texts,
                ..Default::default()
            });
        }
        let (tip, q) = arc.tip();
        let transforms = FrameTransforms {
            transforms: vec![FrameTransform {
                timestamp: Some(stamp),
                parent_frame_id: BASE_FRAME.into(),
                child_frame_id: TIP_FRAME.into(),
                translation: Some(Vector3 {
                    x: tip[0] / 1000.0,
                    y: tip[1] / 1000.0,
                    z: tip[2] / 1000.0,
                }),
                rotation: Some(Quaternion {
                    x: q[0],
                    y: q[1],
                    z: q[2],
                    w: q[3],
                }),
            }],
        };
        Ok((
            SceneUpdate {
                deletions: Vec::new(),
                entities,
            },
            transforms,
        ))
    }
}

/// The simulator's world in the scene, from a `/sim/truth` sample (`tip_mm`,
/// `gripper_closed`, `objects`): each object a 20 mm cube at its grasp point (green while
/// held, orange on the table or where it stands) with its name, and the gripper a sphere at the
/// true tip (dark when closed, light when open). `None` when the sample has no tip.
pub fn world_update(truth: &serde_json::Value, log_time_ns: u64) -> Option<SceneUpdate> {
    let stamp = Timestamp::new(
        (log_time_ns / 1_000_000_000) as u32,
        (log_time_ns % 1_000_000_000) as u32,
    );
    let xyz = |v: &serde_json::Value| -> Option<Vector3> {
        Some(Vector3 {
            x: v.get(0)?.as_f64()? / 1000.0,
            y: v.get(1)?.as_f64()? / 1000.0,
            z: v.get(2)?.as_f64()? / 1000.0,
        })
    };
    let pose = |p: Vector3| Pose {
        position: Some(p),
        orientation: Some(identity()),
    };
    let colour = |r: f64, g: f64, b: f64| Color { r, g, b, a: 1.0 };
    let tip = xyz(&truth["tip_mm"])?;
    let closed = truth["gripper_closed"].as_bool().unwrap_or(false);
    let mut entities = vec![SceneEntity {
        timestamp: Some(stamp),
        frame_id: BASE_FRAME.into(),
        id: "gripper".into(),
        spheres: vec![SpherePrimitive {
            pose: Some(pose(tip)),
            size: Some(Vector3 {
                x: 0.012,
                y: 0.012,
                z: 0.012,
            }),
            color: Some(if closed {
                colour(0.15, 0.15, 0.15)
            } else {
                colour(0.85, 0.85, 0.85)
            }),
        }],
        ..Default::default()
    }];
    for o in truth["objects"].as_array().into_iter().flatten() {
        let Some(at) = xyz(&o["position_mm"]) else {
            continue;
        };
        let name = o["name"].as_str().unwrap_or("object");
        let held = o["held"].as_bool().unwrap_or(false);
        let label = Vector3 {
            z: at.z + 0.02,
            ..at
        };
        entities.push(SceneEntity {
            timestamp: Some(stamp),
            frame_id: BASE_FRAME.into(),
            id: format!("object-{name}"),
            cubes: vec![CubePrimitive {
                pose: Some(pose(at)),
                size: Some(Vector3 {
                    x: 0.02,
                    y: 0.02,
                    z: 0.02,
                }),
                color: Some(if held {
                    colour(0.0, 0.62, 0.45)
                } else {
                    colour(0.9, 0.62, 0.0)
                }),
            }],
            texts: vec![TextPrimitive {
                pose: Some(pose(label)),
                billboard: true,
                font_size: 12.0,
                scale_invariant: true,
                color: Some(colour(1.0, 1.0, 1.0)),
                text: format!("{name}{}", if held { " (held)" } else { "" }),
            }],
            ..Default::default()
        });
    }
    Some(SceneUpdate {
        deletions: Vec::new(),
        entities,
    })
}

fn identity() -> Quaternion {
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    }
}

/// The trunk's colour at `kpa` (RGBA 0–1): from a pale blue at 0 kPa to red at the cap,
/// half transparent while the state is unconfirmed.
pub fn pressure_colour(kpa: f32, limit_kpa: f32, confirmed: bool) -> [f32; 4] {
    let t = if kpa.is_finite() && limit_kpa > 0.0 {
        (kpa / limit_kpa).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let low = [0.55, 0.70, 0.90];
    let high = [0.90, 0.12, 0.10];
    let c = [0, 1, 2].map(|k| low[k] + (high[k] - low[k]) * t);
    [c[0], c[1], c[2], if confirmed { 1.0 } else { 0.5 }]
}

/// A constant-curvature bend of a trunk of height `h` (mm): angle θ toward direction φ, the
/// same model as `geometry::tendon` (the tendon on the inside shortens by r·θ).
#[derive(Debug, Clone, Copy)]
struct Arc {
    bend: Bend,
    h: f64,
}

impl Arc {
    fn new(bend: Bend, h: f64) -> Self {
        Self { bend, h }
    }

    /// Where the point `p` (mm, straight trunk) goes: its height is arc length along the
    /// axis, its offset along φ shrinks the radius of its arc.
    fn map(&self, p: [f64; 3]) -> [f64; 3] {
        let Bend { direction, angle } = self.bend;
        if angle < 1e-9 {
            return p;
        }
        let (s, c) = direction.sin_cos();
        let u = p[0] * c + p[1] * s;
        let w = -p[0] * s + p[1] * c;
        let r = self.h / angle;
        let a = p[2] / r;
        let (u2, z2) = (r - (r - u) * a.cos(), (r - u) * a.sin());
        [u2 * c - w * s, u2 * s + w * c, z2]
    }

    /// The tip's position (mm) and orientation (quaternion x, y, z, w).
    fn tip(&self) -> ([f64; 3], [f64; 4]) {
        let Bend { direction, angle } = self.bend;
        let p = self.map([0.0, 0.0, self.h]);
        // A rotation by θ about the axis (−sin φ, cos φ, 0) turns +Z toward φ.
        let (s, c) = direction.sin_cos();
        let h = 0.5 * angle;
        (p, [-s * h.sin(), c * h.sin(), 0.0, h.cos()])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(state: &str, servo: [f32; 3], kpa: f32) -> Sample {
        Sample {
            state: state.parse().unwrap(),
            confirmed: true,
            servo_deg: servo,
            pressure_kpa: kpa,
        }
    }

    fn max_z(u: &SceneUpdate) -> f64 {
        u.entities
            .iter()
            .flat_map(|e| e.triangles[0].points.iter())
            .map(|p| p.z)
            .fold(f64::MIN, f64::max)
    }

    #[test]
    fn the_world_shows_each_object_and_the_gripper() {
        let truth = serde_json::json!({
            "tip_mm": [0.0, 0.0, 92.5],
            "gripper_closed": true,
            "objects": [
                {"name": "cup", "position_mm": [0.0, 0.0, 92.5], "held": true},
                {"name": "box", "position_mm": [40.0, 0.0, 0.0], "held": false}
            ]
        });
        let u = world_update(&truth, 1_500_000_000).unwrap();
        let ids: Vec<&str> = u.entities.iter().map(|e| e.id.as_str()).collect();
        assert_eq!(ids, ["gripper", "object-cup", "object-box"]);
        let cup = &u.entities[1].cubes[0];
        let p = cup.pose.as_ref().unwrap().position.as_ref().unwrap();
        assert!((p.z - 0.0925).abs() < 1e-12);
        assert_eq!(u.entities[1].texts[0].text, "cup (held)");
        assert!(u.entities[2].cubes[0].color.as_ref().unwrap().r > 0.8);
        assert!(world_update(&serde_json::json!({"tip_mm": null}), 0).is_none());
    }

    #[test]
    fn one_entity_per_module_and_every_index_in_range() {
        let mut s = Scene::crane().unwrap();
        for state in TrunkState::ALL {
            let (u, tf) = s.build(&sample(state.name(), [0.0; 3], 0.0), 5).unwrap();
            assert_eq!(u.entities.len(), 2, "{state}");
            for e in &u.entities {
                let t = &e.triangles[0];
                assert_eq!(t.indices.len() % 3, 0);
                assert!(t.indices.iter().all(|&i| (i as usize) < t.points.len()));
                assert_eq!(e.frame_id, BASE_FRAME);
            }
            assert_eq!(tf.transforms[0].child_frame_id, TIP_FRAME);
        }
    }

    #[test]
    fn heights_follow_the_states() {
        // Deployed is taller than folded, folded taller than self-packed (paper §6.2).
        let mut s = Scene::crane().unwrap();
        let h = |s: &mut Scene, st: &str| max_z(&s.build(&sample(st, [0.0; 3], 0.0), 0).unwrap().0);
        let (dd, df, dp, fp) = (
            h(&mut s, "D&D"),
            h(&mut s, "D&F"),
            h(&mut s, "D&P"),
            h(&mut s, "F&P"),
        );
        assert!(dd > df && df > dp && dp > fp, "{dd} {df} {dp} {fp}");
        // The tip transform sits on the top ring's centre when straight (1 µm).
        let (u, tf) = s.build(&sample("D&D", [0.0; 3], 0.0), 0).unwrap();
        let t = tf.transforms[0].translation.unwrap();
        assert!(t.x.abs() < 1e-6 && t.y.abs() < 1e-6, "{t:?}");
        assert!((t.z - max_z(&u)).abs() < 1e-6, "{} vs {}", t.z, max_z(&u));
    }

    #[test]
    fn pulling_tendon_zero_bends_toward_it_by_the_tendon_kinematics() {
        let mut s = Scene::crane().unwrap();
        // 10° on servo 0 only: 10.47 mm of tendon 0; its differential part is 2/3 of it.
        let bend = s.bend([10.0, 0.0, 0.0]);
        let mm = 10.0 * 60.0 * std::f64::consts::PI / 180.0;
        let want = (2.0 / 3.0) * mm / 60.0;
        assert!((bend.angle - want).abs() < 1e-6, "{} vs {want}", bend.angle);
        assert!(
            bend.direction.abs() < 1e-9
                || (bend.direction - 2.0 * std::f64::consts::PI).abs() < 1e-9
        );
        let (_, tf) = s.build(&sample("D&D", [10.0, 0.0, 0.0], 0.0), 0).unwrap();
        let t = tf.transforms[0].translation.unwrap();
        assert!(t.x > 0.001 && t.y.abs() < 1e-9, "{t:?}");
        // The same pull on all three servos is an axial pull: no bend.
        assert!(s.bend([30.0, 30.0, 30.0]).angle < 1e-9);
    }

    #[test]
    fn the_arc_keeps_the_axis_length_and_shortens_the_inside() {
        let arc = Arc::new(Bend::new(0.3, 0.8), 200.0);
        // The axis keeps its length: the tip is at chord 2R·sin(θ/2) from the base.
        let (tip, q) = arc.tip();
        let r = 200.0 / 0.8;
        let chord = (tip[0].powi(2) + tip[1].powi(2) + tip[2].powi(2)).sqrt();
        assert!((chord - 2.0 * r * (0.4f64).sin()).abs() < 1e-9);
        // A line at radius 60 mm on the inside is 60·θ shorter (the tendon model).
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let steps = 2000;
        let mut len = 0.0;
        let mut prev = arc.map([60.0 * c, 60.0 * s, 0.0]);
        for i in 1..=steps {
            let p = arc.map([60.0 * c, 60.0 * s, 200.0 * i as f64 / steps as f64]);
            len += ((p[0] - prev[0]).powi(2) + (p[1] - prev[1]).powi(2) + (p[2] - prev[2]).powi(2))
                .sqrt();
            prev = p;
        }
        assert!((len - (200.0 - 60.0 * 0.8)).abs() < 1e-3, "{len}");
        // The quaternion is a unit one.
        let n: f64 = q.iter().map(|x| x * x).sum();
        assert!((n - 1.0).abs() < 1e-12);
    }

    #[test]
    fn pressure_colour_ends_and_out_of_range() {
        let near = |a: [f32; 4], b: [f32; 4]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
        assert!(near(
            pressure_colour(0.0, 40.0, true),
            [0.55, 0.70, 0.90, 1.0]
        ));
        assert!(near(
            pressure_colour(20.0, 40.0, true),
            [0.725, 0.41, 0.50, 1.0]
        ));
        assert!(near(
            pressure_colour(40.0, 40.0, true),
            [0.90, 0.12, 0.10, 1.0]
        ));
        assert!(near(
            pressure_colour(99.0, 40.0, false),
            [0.90, 0.12, 0.10, 0.5]
        ));
        assert!(near(
            pressure_colour(-3.0, 40.0, true),
            [0.55, 0.70, 0.90, 1.0]
        ));
        assert!(near(
            pressure_colour(f32::NAN, 40.0, true),
            [0.55, 0.70, 0.90, 1.0]
        ));
    }
}
