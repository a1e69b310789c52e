//! The hand-written in-place `Deserialize` of `Plan` and `Step` (`protocol::messages::in_place`)
//! against derived twins of both types: the same bytes give the same value or both an error, on
//! valid plans, every truncation, single-byte mutations and sequences over capacity.

use geometry::TrunkState;
use proptest::collection::vec;
use proptest::prelude::*;
use protocol::*;
use serde::Deserialize;

use crate::props::step;

/// postcard bytes of `v` (no `alloc` feature here: through a buffer).
fn to_vec<T: serde::Serialize>(v: &T) -> Vec<u8> {
    let mut buf = [0u8; 1024];
    postcard::to_slice(v, &mut buf).unwrap().to_vec()
}

/// `Step` with the derive.
#[derive(Debug, Deserialize)]
struct StepTwin {
    kind: StepKind,
    from: TrunkState,
    to: TrunkState,
    primitives: heapless::Vec<Primitive, MAX_STEP_PRIMITIVES>,
    timeout_ms: u32,
}

/// `Plan` with the derive.
#[derive(Debug, Deserialize)]
struct PlanTwin {
    plan_id: u16,
    steps: heapless::Vec<StepTwin, MAX_PLAN_STEPS>,
}

fn from_twin(t: StepTwin) -> Step {
    Step {
        kind: t.kind,
        from: t.from,
        to: t.to,
        primitives: t.primitives,
        timeout_ms: t.timeout_ms,
    }
}

/// Both deserialisers on `bytes` (the whole input must be used, as the frame decoder wants).
fn both(bytes: &[u8]) -> (Option<Plan>, Option<Plan>) {
    let ours = postcard::from_bytes::<Plan>(bytes).ok();
    let twin = postcard::from_bytes::<PlanTwin>(bytes).ok().map(|t| Plan {
        plan_id: t.plan_id,
        steps: t.steps.into_iter().map(from_twin).collect(),
    });
    (ours, twin)
}

fn plan(id: u16, steps: &[Step]) -> Plan {
    Plan {
        plan_id: id,
        steps: heapless::Vec::from_slice(steps).unwrap(),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn the_in_place_plan_decodes_as_the_derive_on_valid_truncated_and_mutated_bytes(
        id in any::<u16>(),
        steps in vec(step(), 0..=MAX_PLAN_STEPS),
        flips in vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
    ) {
        let p = plan(id, &steps);
        let bytes = to_vec(&p);
        let (ours, twin) = both(&bytes);
        prop_assert_eq!(ours.as_ref(), Some(&p));
        prop_assert_eq!(&ours, &twin);
        for n in 0..bytes.len() {
            let (ours, twin) = both(&bytes[..n]);
            prop_assert!(ours.is_none() && twin.is_none(), "{} of {} bytes", n, bytes.len());
        }
        let mut m = bytes.clone();
        for (at, x) in &flips {
            let i = at.index(m.len());
            m[i] ^= x | 1;
        }
        // Compared by their bytes: a mutated float may be NaN, which is not `==` to itself.
        let (ours, twin) = both(&m);
        prop_assert_eq!(ours.map(|p| to_vec(&p)), twin.map(|p| to_vec(&p)));
    }

    #[test]
    fn a_step_alone_decodes_as_the_derive(s in step(), cut in any::<prop::sample::Index>()) {
        let bytes = to_vec(&s);
        prop_assert_eq!(postcard::from_bytes::<Step>(&bytes).unwrap(), s.clone());
        let n = cut.index(bytes.len());
        prop_assert!(postcard::from_bytes::<Step>(&bytes[..n]).is_err());
        prop_assert!(postcard::from_bytes::<StepTwin>(&bytes[..n]).is_err());
    }
}

/// One step or primitive more than the capacity is refused by both (postcard writes the
/// length as a varint, one byte here: patched, and the extra element appended).
#[test]
fn one_more_than_the_capacity_is_refused_by_both() {
    let s = Step {
        kind: StepKind::Tendon,
        from: TrunkState::ALL[0],
        to: TrunkState::ALL[1],
        primitives: heapless::Vec::from_slice(&[Primitive::Hold { duration_ms: 5 }; 4]).unwrap(),
        timeout_ms: 9,
    };
    let full = plan(7, &vec![s.clone(); MAX_PLAN_STEPS]);
    let mut bytes = to_vec(&full);
    assert_eq!(both(&bytes), (Some(full.clone()), Some(full)));
    // plan_id 7 is one varint byte; the steps' length follows it.
    assert_eq!(bytes[1], MAX_PLAN_STEPS as u8);
    bytes[1] += 1;
    bytes.extend(to_vec(&s));
    assert_eq!(both(&bytes), (None, None));

    // A step of five primitives: kind, from (2), to (2) bytes, then the primitives' length.
    let mut one = to_vec(&s);
    assert_eq!(one[5], MAX_STEP_PRIMITIVES as u8);
    one[5] += 1;
    one.splice(6..6, to_vec(&Primitive::Hold { duration_ms: 5 }));
    assert!(postcard::from_bytes::<Step>(&one).is_err());
    assert!(postcard::from_bytes::<StepTwin>(&one).is_err());
    let mut p = vec![7u8, 1];
    p.extend(&one);
    assert_eq!(both(&p), (None, None));
}
