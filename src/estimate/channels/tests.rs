use super::*;

#[test]
fn channels_are_listed_in_index_order_with_distinct_keys_and_streams() {
    use crate::noise::Stream;
    for (i, c) in Channel::ALL.into_iter().enumerate() {
        assert_eq!(c.index(), i);
        assert!(matches!(c.stream(), Stream::Channel(_)), "{c:?}");
        for d in &Channel::ALL[i + 1..] {
            assert_ne!(c.key(), d.key());
            assert_ne!(
                c.stream().id(),
                d.stream().id(),
                "{c:?} and {d:?} share a stream"
            );
        }
        for other in Stream::OTHERS {
            assert_ne!(
                c.stream().id(),
                other.id(),
                "{c:?} takes {other:?}'s identifier"
            );
        }
    }
    // The identifiers the engine's numbers were pinned with (docs/model.md#streams).
    let ids: Vec<u64> = Channel::ALL.iter().map(|c| c.stream().id()).collect();
    assert_eq!(ids[..5], [1, 2, 3, 4, 9]);
}

#[test]
fn a_zero_draw_leaves_the_samples_unchanged() {
    use crate::numeric::simd::Scalar;
    let reg = crate::estimate::regression::test_regression();
    for j in [0, 100, reg.len() - 1] {
        let noise_free = Sample {
            force: reg.f[j],
            speed: reg.v[j],
            c: reg.c[j],
            s: reg.g_sin[j],
            output_noise: None,
        };
        // A channel whose noise at σ = 0 moves nothing is not run (`moves_at`).
        for c in Channel::ALL.into_iter().filter(|c| c.moves_at(0.0)) {
            let mut x = noise_free;
            c.measure(Scalar, &mut x, 0.0, 0.0);
            assert_eq!(x.output_noise.unwrap_or(0.0), 0.0, "{c:?}");
            x.output_noise = None;
            assert_eq!(x, noise_free, "{c:?}");
        }
    }
}

#[test]
fn each_signal_has_one_channel_and_each_channel_one_signal() {
    for signal in Signal::ALL {
        let measuring: Vec<Channel> = Channel::ALL
            .into_iter()
            .filter(|c| c.signal() == signal)
            .collect();
        assert_eq!(measuring.first(), Some(&Channel::of(signal)), "{signal:?}");
    }
}
