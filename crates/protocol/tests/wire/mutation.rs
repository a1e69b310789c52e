//! A 10^6-frame run of the mutation campaign (the 10^8 one is the `mutation` bench binary).

#[path = "../../benches/support/mutation_campaign.rs"]
mod mutation_campaign;

#[test]
fn a_million_mutated_frames_none_accepted() {
    let r = mutation_campaign::campaign(1_000_000, 7, false);
    assert_eq!(r.frames, 1_000_000);
    // Both kinds of error are exercised, about half each.
    assert!((400_000..600_000).contains(&r.bit_error_frames), "{r:?}");
    assert_eq!(r.accepted_v2, 0, "{r:?}");
}

#[test]
fn every_mutation_changes_the_frame_and_stays_in_it() {
    let mut rng = mutation_campaign::Rng::new(3);
    for s in mutation_campaign::samples() {
        for _ in 0..1_000 {
            let mut f = s.v2.clone();
            mutation_campaign::mutate(&mut f, &mut rng);
            assert_eq!(f.len(), s.v2.len());
            assert_ne!(f, s.v2);
        }
    }
}
