//! A tiny deterministic PRNG for everything the bake randomises (the `random` patch order,
//! sampled error estimates), so a bake is reproducible from its seed and needs no `rand`.

/// SplitMix64 (Steele, Lea & Flood 2014, the seeder of `java.util.SplittableRandom`): one
/// 64-bit state, an add and two multiply-xorshifts per output; passes BigCrush. Not for
/// cryptography. The same sequence as the test fixtures' generator for the same seed.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` with 24 random bits.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Eight random bytes (the next 64 bits, little-endian).
    pub fn next_bytes(&mut self) -> [u8; 8] {
        self.next_u64().to_le_bytes()
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `0..bound`, without modulo bias (Lemire's multiply-shift with rejection).
    /// Panics if `bound` is 0.
    pub fn below(&mut self, bound: u64) -> u64 {
        assert!(bound > 0, "SplitMix64::below(0)");
        let threshold = bound.wrapping_neg() % bound; // 2^64 mod bound
        loop {
            let m = u128::from(self.next_u64()) * u128::from(bound);
            if (m as u64) >= threshold {
                return (m >> 64) as u64;
            }
        }
    }

    /// Shuffles `items` in place (Fisher–Yates): every permutation equally likely.
    pub fn shuffle<T>(&mut self, items: &mut [T]) {
        for i in (1..items.len()).rev() {
            let j = self.below(i as u64 + 1) as usize;
            items.swap(i, j);
        }
    }
}

/// Point `k` of the first two dimensions of Sobol's sequence (van der Corput in base 2, and
/// the dimension of polynomial `x + 1`), each XOR-scrambled by `scramble` (a random digital
/// shift), in `[0, 1)²`. Every prefix of `2^m` points has exactly one point in each of the
/// `2^m` equal slices of either axis: a region along an edge of the square wider than a slice
/// cannot be missed, and its share is measured far more closely than by independent uniform
/// points. Used for the buried share of a patch (`closure::buried_by_object`) and for where
/// shadow rays start on their quadrature leaf (`quadrature::Sample::leaf_point`). (Roberts'
/// R2 sequence was tried first: its first 32 points leave a gap of 0.11 in the first
/// coordinate, and missed a wall patch 8% buried in five of eight shifts.)
pub fn sobol2(scramble: [u32; 2], k: u32) -> [f64; 2] {
    let mut second = 0u32;
    let mut direction = 1u32 << 31;
    for bit in 0..32 {
        if k >> bit & 1 == 1 {
            second ^= direction;
        }
        direction ^= direction >> 1;
    }
    let unit = |x: u32| f64::from(x) / 4_294_967_296.0;
    [
        unit(k.reverse_bits() ^ scramble[0]),
        unit(second ^ scramble[1]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The property `sobol2` is used for: under any scramble, every prefix of 2^m points has
    /// exactly one point in each 1/2^m slice of either axis (m up to 9, the buried share's 512).
    #[test]
    fn sobol_prefixes_are_stratified_on_both_axes() {
        for scramble in [[0, 0], [0x9e37_79b9, 0x7f4a_7c15], [u32::MAX, 12345]] {
            for m in 0..=9 {
                let n = 1u32 << m;
                for axis in 0..2 {
                    let mut seen = vec![false; n as usize];
                    for k in 0..n {
                        let x = sobol2(scramble, k)[axis];
                        assert!((0.0..1.0).contains(&x));
                        let slice = (x * f64::from(n)) as usize;
                        assert!(
                            !seen[slice],
                            "{scramble:?} m {m} axis {axis}: slice {slice} twice"
                        );
                        seen[slice] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn matches_the_reference_sequence() {
        // First outputs for seed 1234567 from the reference C implementation (Vigna's
        // splitmix64.c), as listed in the SplittableRandom test vectors.
        let mut r = SplitMix64(1_234_567);
        assert_eq!(r.next_u64(), 6_457_827_717_110_365_317);
        assert_eq!(r.next_u64(), 3_203_168_211_198_807_973);
        assert_eq!(r.next_u64(), 9_817_491_932_198_370_423);
    }

    #[test]
    fn below_is_in_range_and_covers_it() {
        let mut r = SplitMix64(9);
        let mut seen = [0u32; 7];
        for _ in 0..7000 {
            seen[r.below(7) as usize] += 1;
        }
        // Each of 7 outcomes expects 1000; ±200 is over 6 standard deviations (σ ≈ 30).
        assert!(seen.iter().all(|c| (800..1200).contains(c)), "{seen:?}");
    }

    #[test]
    fn shuffle_is_a_permutation() {
        let mut v: Vec<u32> = (0..1000).collect();
        SplitMix64(3).shuffle(&mut v);
        assert_ne!(v, (0..1000).collect::<Vec<_>>());
        v.sort_unstable();
        assert_eq!(v, (0..1000).collect::<Vec<_>>());
    }
}
