use super::*;

#[test]
fn seen_realisations_are_ranges_and_duplicates_are_found_in_any_order() {
    let mut seen = Seen::default();
    // Two shards' worth, the second first, as summarize may read them.
    for r in (50..100).chain(0..50) {
        assert!(seen.mark(r), "{r} is new");
    }
    assert_eq!(
        seen.ranges.len(),
        1,
        "adjacent ranges merge: {:?}",
        seen.ranges
    );
    assert_eq!(seen.ranges.get(&0), Some(&100));
    for r in [0, 49, 50, 99] {
        assert!(!seen.mark(r), "{r} again");
    }
    // A gap, then the gap filled from both sides.
    assert!(seen.mark(102));
    assert!(seen.mark(101));
    assert!(seen.mark(100));
    assert_eq!(seen.ranges.len(), 1);
    assert_eq!(seen.ranges.get(&0), Some(&103));
}
