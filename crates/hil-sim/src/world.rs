//! A world around the simulated crane: objects on the table, the gripper that captures them,
//! a load hung on the tip, and the true pose of the tip.
//!
//! The table is the base plane z = 0 (the crane stands on it, the objects rest on it or on
//! what the caller says they stand on: an object is placed at its grasp point). Closing the
//! gripper with its tip within [`CAPTURE_RADIUS_MM`] of an object's grasp point holds the
//! nearest such object: its weight joins the tip load (the physics' `payload_n`) and it moves
//! with the tip. Opening releases whatever is held where the tip is; it falls to the table
//! (z = 0) below the tip. A tip load (`--tip-load-kg`) hangs on the tip whatever the gripper
//! does (a weight tied to it, §6.5).
//!
//! The true tip: the physics keeps the two module heights and one bend vector (the tip axis's
//! tilt θ toward φ). The bend moment is the same through both modules, so each takes the share
//! of θ its compliance gives it, θ_i = θ·(1/k_i)/(1/k_top + 1/k_bottom), with k_i the bending
//! stiffness of the basin it is in (`TrunkParams`), and each is a constant-curvature arc of its
//! own height. `docs/geometry.md` ("Tip pose and workspace") compares this with the geometry's
//! constant curvature over the flexible length.

use geometry::reach::{chain_in_plane, pose_from_plane, TipPose};

use crate::physics::Trunk;

/// How near the gripper's tip must be to an object's grasp point to hold it, mm.
pub const CAPTURE_RADIUS_MM: f64 = 15.0;
/// Standard gravity, m/s².
pub const G: f64 = 9.81;
/// The heaviest object or tip load accepted, kg (well above what any state holds: the physics
/// then collapses the trunk, which is the point of asking for it).
pub const MAX_MASS_KG: f64 = 50.0;
/// Objects further from the base than this are refused, mm (no state reaches past ≈ 200 mm).
pub const MAX_DISTANCE_MM: f64 = 2_000.0;

/// Why an object or a load was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WorldError {
    /// Bad `NAME:X,Y,Z[,MASS_KG]` text.
    #[error("object '{0}': expected NAME:X,Y,Z[,MASS_KG] (mm, kg), e.g. cup:40,0,60,0.05")]
    Syntax(String),
    /// A number outside its range.
    #[error("{0}")]
    Range(String),
    /// Two objects with one name.
    #[error("two objects are named '{0}': names must differ")]
    Duplicate(String),
}

/// An object in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    /// Its name.
    pub name: String,
    /// Its grasp point, mm (base frame).
    pub position_mm: [f64; 3],
    /// Mass, kg.
    pub mass_kg: f64,
    /// The gripper holds it.
    pub held: bool,
}

impl Object {
    /// Parses `NAME:X,Y,Z[,MASS_KG]` (mm, kg; the mass defaults to 0.05 kg).
    pub fn parse(text: &str) -> Result<Object, WorldError> {
        let syntax = || WorldError::Syntax(text.to_string());
        let (name, rest) = text.split_once(':').ok_or_else(syntax)?;
        let name = name.trim();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "_-".contains(c))
        {
            return Err(WorldError::Syntax(format!(
                "{text}' (a name is letters, digits, '-' and '_'"
            )));
        }
        let nums: Vec<f64> = rest
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| syntax())?;
        if !(3..=4).contains(&nums.len()) {
            return Err(syntax());
        }
        let position_mm = [nums[0], nums[1], nums[2]];
        if !position_mm.iter().all(|v| v.is_finite()) || position_mm[2] < 0.0 {
            return Err(WorldError::Range(format!(
                "object '{name}': its point must be finite and on or above the table (z ≥ 0 mm), got z = {} mm",
                position_mm[2]
            )));
        }
        let dist =
            (position_mm[0].powi(2) + position_mm[1].powi(2) + position_mm[2].powi(2)).sqrt();
        if dist > MAX_DISTANCE_MM {
            return Err(WorldError::Range(format!(
                "object '{name}' is {dist:.0} mm from the base: at most {MAX_DISTANCE_MM:.0} mm"
            )));
        }
        let mass_kg = nums.get(3).copied().unwrap_or(0.05);
        check_mass(&format!("object '{name}': its mass"), mass_kg)?;
        Ok(Object {
            name: name.to_string(),
            position_mm,
            mass_kg,
            held: false,
        })
    }
}

fn check_mass(what: &str, kg: f64) -> Result<(), WorldError> {
    if kg.is_finite() && (0.0..=MAX_MASS_KG).contains(&kg) {
        Ok(())
    } else {
        Err(WorldError::Range(format!(
            "{what} must be in [0, {MAX_MASS_KG}] kg, got {kg}"
        )))
    }
}

/// What happened to the gripper's hold in one step.
#[derive(Debug, Clone, PartialEq)]
pub enum Grasp {
    /// The gripper closed on this object.
    Captured(String),
    /// The gripper closed on nothing (the nearest object and its distance, mm, if any).
    Missed(Option<(String, f64)>),
    /// The gripper opened and let this object fall to the table.
    Released(String),
}

/// Objects, the tip load and the gripper's hold.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct World {
    objects: Vec<Object>,
    tip_load_kg: f64,
    gripper_closed: bool,
    tip: Option<TipPose>,
    events: Vec<Grasp>,
}

impl World {
    /// An empty world: no object, no tip load.
    pub fn new() -> World {
        World::default()
    }

    /// A world with `objects` (names distinct) and `tip_load_kg` on the tip.
    pub fn with(objects: Vec<Object>, tip_load_kg: f64) -> Result<World, WorldError> {
        check_mass("--tip-load-kg", tip_load_kg)?;
        for (i, o) in objects.iter().enumerate() {
            if objects[..i].iter().any(|p| p.name == o.name) {
                return Err(WorldError::Duplicate(o.name.clone()));
            }
        }
        Ok(World {
            objects,
            tip_load_kg,
            ..World::default()
        })
    }

    /// Puts `object` into the world, as a person places it at the crane (not held: only
    /// closing the gripper catches). Refused when an object of that name is already there.
    pub fn place(&mut self, object: Object) -> Result<(), WorldError> {
        if self.objects.iter().any(|o| o.name == object.name) {
            return Err(WorldError::Duplicate(object.name));
        }
        self.objects.push(Object {
            held: false,
            ..object
        });
        Ok(())
    }

    /// Tells the world where the gripper is without catching or dropping anything (objects
    /// placed at a closed gripper are not held; only closing catches).
    pub fn set_gripper(&mut self, closed: bool) {
        self.gripper_closed = closed;
    }

    /// The objects.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// The load hung on the tip, kg.
    pub fn tip_load_kg(&self) -> f64 {
        self.tip_load_kg
    }

    /// Whether the world holds nothing (no object, no load): the simulator then runs as
    /// without one.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty() && self.tip_load_kg == 0.0
    }

    /// The tip's true pose after the last step (`None` before the first).
    pub fn tip(&self) -> Option<TipPose> {
        self.tip
    }

    /// What the gripper caught or let go of since the last call.
    pub fn take_events(&mut self) -> Vec<Grasp> {
        std::mem::take(&mut self.events)
    }

    /// The weight on the tip, N: the tip load and everything held.
    pub fn load_n(&self) -> f64 {
        let held: f64 = self
            .objects
            .iter()
            .filter(|o| o.held)
            .map(|o| o.mass_kg)
            .sum();
        (self.tip_load_kg + held) * G
    }

    /// After a physics step: the tip moves, the gripper (its output `closed`) catches or lets
    /// go.
    pub fn after_step(&mut self, trunk: &Trunk, closed: bool) {
        let tip = true_tip(trunk);
        self.tip = Some(tip);
        for o in self.objects.iter_mut().filter(|o| o.held) {
            o.position_mm = tip.position_mm;
        }
        if closed == self.gripper_closed {
            return;
        }
        self.gripper_closed = closed;
        if closed {
            let nearest = self
                .objects
                .iter_mut()
                .map(|o| (dist(o.position_mm, tip.position_mm), o))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match nearest {
                Some((d, o)) if d <= CAPTURE_RADIUS_MM => {
                    o.held = true;
                    o.position_mm = tip.position_mm;
                    self.events.push(Grasp::Captured(o.name.clone()));
                }
                Some((d, o)) => self.events.push(Grasp::Missed(Some((o.name.clone(), d)))),
                None => self.events.push(Grasp::Missed(None)),
            }
        } else {
            for o in self.objects.iter_mut().filter(|o| o.held) {
                o.held = false;
                o.position_mm = [tip.position_mm[0], tip.position_mm[1], 0.0];
                self.events.push(Grasp::Released(o.name.clone()));
            }
        }
    }

    /// The world as JSON: the tip, the tip load and every object.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "tip_mm": self.tip.map(|t| t.position_mm.map(round3)),
            "tip_axis": self.tip.map(|t| t.axis.map(|v| (v * 1e6).round() / 1e6)),
            "tip_load_kg": self.tip_load_kg,
            "objects": self.objects.iter().map(|o| serde_json::json!({
                "name": o.name,
                "position_mm": o.position_mm.map(round3),
                "mass_kg": o.mass_kg,
                "held": o.held,
            })).collect::<Vec<_>>(),
        })
    }
}

fn round3(v: f64) -> f64 {
    (v * 1e3).round() / 1e3
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The tip's true pose: each module a constant-curvature arc of its height taking the share of
/// the bend its bending compliance gives it (see the module text).
pub fn true_tip(trunk: &Trunk) -> TipPose {
    let [h_top, h_bottom] = trunk.heights_mm();
    let (theta_deg, phi_deg) = trunk.bend_deg();
    let theta = theta_deg.to_radians();
    let p = trunk.params();
    let kt = p.top_bending_n_mm_per_rad[p.top.basin(h_top).min(1)];
    let kb = p.bottom_bending_n_mm_per_rad[p.bottom.basin(h_bottom).min(3)];
    let (ct, cb) = (1.0 / kt, 1.0 / kb);
    let (th_b, th_t) = (theta * cb / (ct + cb), theta * ct / (ct + cb));
    let (rho, z, tilt) = chain_in_plane(&[(h_bottom, th_b), (h_top, th_t)]);
    pose_from_plane(rho, z, tilt, phi_deg.to_radians())
}

/// Calibrates each flexible state of `ws` against the simulator, as a crane would be
/// calibrated with a tip sensor: one bend of half the state's limit toward tendon 0 (where the
/// bend stays in its plane) through the controller, on a fresh simulator; the true tip axis
/// gives the gain (true bend per commanded degree), the true tip's sideways offset the bottom
/// module's share of the bend, its height the sag under the tendons' pull; a bend toward 60°
/// (midway between two tendons) the gain there, one toward 30° the lean toward the nearer
/// tendon. The calibrated workspace then predicts the simulator's tip
/// (docs/geometry.md, "Tip pose and workspace").
pub fn calibrate(
    mut ws: planner::task::Workspace,
    cfg: &protocol::CraneGeometry,
) -> Result<planner::task::Workspace, String> {
    use geometry::reach::side_tip_split;
    use geometry::TrunkState;
    let tg = geometry::tendon::TendonGeometry::new(f64::from(cfg.tendon_radius_mm))
        .map_err(|e| format!("the tendon radius: {e}"))?;
    let bent = |ws: &planner::task::Workspace, state: TrunkState, angle: f64, dir: f64| {
        let mut sim = crate::Sim::new(crate::SimOptions {
            initial: state,
            ..crate::SimOptions::default()
        });
        let mut host = crate::host::SimHost::new();
        host.hello(&mut sim)
            .map_err(|e| format!("{state}: {e:?}"))?;
        let bend = ws
            .check_bend(state, angle, dir)
            .map_err(|e| format!("{state}: {e}"))?;
        let cmd = tg.command_for(bend, f64::from(cfg.take_up_margin_mm));
        let step = planner::task::step_within(
            state,
            protocol::StepKind::Tendon,
            &[planner::task::bend_primitive(cmd)],
        );
        let (ok, _) = host
            .run_plan(&mut sim, 1, &[step], 30_000)
            .map_err(|e| format!("{state}: {e:?}"))?;
        if !ok {
            return Err(format!("{state}: the bend toward {dir}° failed"));
        }
        for _ in 0..1_000 {
            let _ = host.poll(&mut sim);
        }
        Ok(sim.true_tip())
    };
    for state in TrunkState::ALL {
        let Some(limit) = ws.limit_deg(state) else {
            continue;
        };
        let angle = 0.5 * limit;
        let a = angle.to_radians();
        // Toward tendon 0 (the bend stays in its plane): the gain there, the split, the sag.
        let tip = bent(&ws, state, angle, 0.0)?;
        let tilt = tip.axis[0].atan2(tip.axis[2]);
        let gain = tilt / a;
        // The tip's offset grows with the bottom's share at a given total bend: bisect.
        let heights = *ws.heights();
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if side_tip_split(&heights, state, tilt, mid).0 < tip.position_mm[0] {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let share = 0.5 * (lo + hi);
        let sag_mm_per_rad =
            (side_tip_split(&heights, state, tilt, share).1 - tip.position_mm[2]) / a;
        // Toward 60° (midway between two tendons: no lean there), the gain between.
        let t60 = bent(&ws, state, angle, 60.0)?;
        let gain_between = t60.axis[2].clamp(-1.0, 1.0).acos() / a;
        // Toward 30° (where sin 3φ = 1): how far the tip turns toward tendon 0.
        let t30 = bent(&ws, state, angle, 30.0)?;
        let lean = 30f64.to_radians() - t30.axis[1].atan2(t30.axis[0]);
        // Where the bend snaps to the tendon (D&P: stiff, one tendon pulls) the lean model does
        // not hold: no lean is modelled there.
        let lean_rad = if lean.abs() < 0.3 { lean } else { 0.0 };
        ws = ws
            .with_calibration(
                state,
                planner::task::Calibration {
                    gain,
                    gain_between,
                    bottom_share: share,
                    sag_mm_per_rad,
                    lean_rad,
                },
            )
            .map_err(|e| format!("{state}: {e}"))?;
    }
    Ok(ws)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::TrunkParams;
    use geometry::TrunkState;

    #[test]
    fn objects_parse_and_bad_ones_name_what_is_expected() {
        let o = Object::parse("cup:40,-5.5,60,0.2").unwrap();
        assert_eq!(o.name, "cup");
        assert_eq!(o.position_mm, [40.0, -5.5, 60.0]);
        assert_eq!(o.mass_kg, 0.2);
        assert_eq!(Object::parse("b:1,2,3").unwrap().mass_kg, 0.05);
        for bad in [
            "cup",
            "cup:1,2",
            "cup:1,2,3,4,5",
            ":1,2,3",
            "c p:1,2,3",
            "cup:a,2,3",
        ] {
            let e = Object::parse(bad).unwrap_err().to_string();
            assert!(e.contains("NAME:X,Y,Z"), "{bad}: {e}");
        }
        assert!(Object::parse("cup:0,0,-1")
            .unwrap_err()
            .to_string()
            .contains("z ≥ 0"));
        assert!(Object::parse("cup:0,0,1,-1")
            .unwrap_err()
            .to_string()
            .contains("[0, 50]"));
        assert!(Object::parse("cup:0,0,1,nan").is_err());
        assert!(Object::parse("cup:3000,0,1")
            .unwrap_err()
            .to_string()
            .contains("2000"));
        let two = vec![
            Object::parse("a:0,0,1").unwrap(),
            Object::parse("a:0,0,2").unwrap(),
        ];
        assert_eq!(
            World::with(two, 0.0),
            Err(WorldError::Duplicate("a".into()))
        );
        assert!(World::with(vec![], 51.0).is_err());
    }

    #[test]
    fn the_gripper_holds_what_is_near_and_drops_it_below_the_tip() {
        let trunk = Trunk::new(
            TrunkParams::pdf().unwrap(),
            "F&F".parse::<TrunkState>().unwrap(),
        );
        let top = trunk.height_mm();
        let near = Object::parse(&format!("near:3,4,{top}")).unwrap(); // 5 mm away
        let far = Object::parse(&format!("far:100,0,{top}")).unwrap();
        let mut w = World::with(vec![near, far], 1.0).unwrap();
        w.after_step(&trunk, false);
        assert!((w.load_n() - G).abs() < 1e-12, "only the tip load");
        w.after_step(&trunk, true);
        assert_eq!(w.take_events(), vec![Grasp::Captured("near".into())]);
        assert!((w.load_n() - 1.05 * G).abs() < 1e-9);
        assert_eq!(w.objects()[0].position_mm, w.tip().unwrap().position_mm);
        w.after_step(&trunk, false);
        assert_eq!(w.take_events(), vec![Grasp::Released("near".into())]);
        let o = &w.objects()[0];
        assert!(!o.held && o.position_mm[2] == 0.0);
        // Closing far from everything catches nothing, and says how far the nearest was.
        let mut w = World::with(vec![Object::parse("x:60,0,0").unwrap()], 0.0).unwrap();
        w.after_step(&trunk, true);
        match &w.take_events()[..] {
            [Grasp::Missed(Some((name, d)))] => {
                assert_eq!(name, "x");
                assert!((d - (60f64.powi(2) + top * top).sqrt()).abs() < 1e-6);
            }
            e => panic!("{e:?}"),
        }
        assert_eq!(w.load_n(), 0.0);
    }

    /// A person places an object at a closed gripper while the crane runs: it is not held
    /// until the gripper opens and closes again; a second object of that name is refused.
    #[test]
    fn an_object_placed_at_a_closed_gripper_is_caught_only_by_the_next_closing() {
        let trunk = Trunk::new(
            TrunkParams::pdf().unwrap(),
            "F&P".parse::<TrunkState>().unwrap(),
        );
        let top = trunk.height_mm();
        let mut w = World::new();
        w.set_gripper(true);
        let cup = Object::parse(&format!("cup:0,0,{top}")).unwrap();
        w.place(cup.clone()).unwrap();
        assert_eq!(
            w.place(cup),
            Err(WorldError::Duplicate("cup".into())),
            "one object per name"
        );
        w.after_step(&trunk, true);
        assert!(w.take_events().is_empty() && !w.objects()[0].held);
        w.after_step(&trunk, false);
        assert!(w.take_events().is_empty(), "nothing held, nothing dropped");
        w.after_step(&trunk, true);
        assert_eq!(w.take_events(), vec![Grasp::Captured("cup".into())]);
    }

    #[test]
    fn a_straight_trunk_has_its_tip_on_the_axis_at_its_height() {
        for s in TrunkState::ALL {
            let trunk = Trunk::new(TrunkParams::pdf().unwrap(), s);
            let t = true_tip(&trunk);
            assert!(t.position_mm[0].abs() < 1e-12 && t.position_mm[1].abs() < 1e-12);
            assert!((t.position_mm[2] - trunk.height_mm()).abs() < 1e-9);
        }
    }
}
