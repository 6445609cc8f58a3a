use super::*;
use crate::estimate::channels::Channel;
use crate::estimate::regression::test_regression as regression;
use crate::noise::NormalStream;

#[test]
fn vector_block_sums_equal_the_portable_ones_bit_for_bit_and_write_w() {
    let reg = regression();
    let mut e = [0.0; BLOCK];
    NormalStream::for_realisation(5, 0, Channel::Velocity.stream(), 1).fill(&mut e);
    let mut eta = [0.0; BLOCK];
    NormalStream::for_realisation(5, 0, Channel::Output.stream(), 1).fill(&mut eta);
    for (start, len) in [(0, BLOCK), (1000, 253), (3, 7)] {
        let cols = Columns {
            v: &reg.v[start..start + len],
            f: &reg.f[start..start + len],
            c: &reg.c[start..start + len],
            y: &reg.y[start..start + len],
        };
        let portable = speed_sums_lanes::<_, false>(Quad, &cols, &e[..len], 0.8, &mut []);
        let dispatched = speed_sums(&cols, &e[..len], 0.8);
        assert_eq!(portable.map(f64::to_bits), dispatched.map(f64::to_bits));
        // Writing w changes no sum, and writes the w of each sample, every one of them
        // (the two writers start from values no w can take).
        let (mut w_portable, mut w_dispatched) = (vec![-1.0; len], vec![-2.0; len]);
        let writing = speed_sums_lanes::<_, true>(Quad, &cols, &e[..len], 0.8, &mut w_portable);
        assert_eq!(writing.map(f64::to_bits), portable.map(f64::to_bits));
        let writing = speed_sums_writing_w(&cols, &e[..len], 0.8, &mut w_dispatched);
        assert_eq!(writing.map(f64::to_bits), portable.map(f64::to_bits));
        for (j, (a, b)) in w_portable.iter().zip(&w_dispatched).enumerate() {
            let vt = cols.v[j] + 0.8 * e[j];
            assert_eq!(
                (a.to_bits(), b.to_bits()),
                ((vt * vt).to_bits(), (vt * vt).to_bits())
            );
        }
        let portable = output_sums_lanes(Quad, &cols, &e[..len], 0.8, &eta[..len]);
        let dispatched = output_sums(&cols, &e[..len], 0.8, &eta[..len]);
        assert_eq!(portable.map(f64::to_bits), dispatched.map(f64::to_bits));
    }
}
