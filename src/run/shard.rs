//! Shards: contiguous realisation ranges of every condition, run as separate processes.

/// Shard K of N: the contiguous realisations ⌊K·R/N⌋ … ⌊(K+1)·R/N⌋ − 1 of every condition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// K, 0-based.
    pub index: u64,
    /// N ≥ 1.
    pub count: u64,
}

impl Shard {
    /// Parse "K/N" with 0 ≤ K < N.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| format!("expected K/N (e.g. 0/4), got \"{text}\""))?;
        let index: u64 = k
            .trim()
            .parse()
            .map_err(|_| format!("K in K/N must be a whole number, got \"{k}\""))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("N in K/N must be a whole number, got \"{n}\""))?;
        if count == 0 || index >= count {
            return Err(format!("need 0 <= K < N, got {index}/{count}"));
        }
        Ok(Shard { index, count })
    }

    /// The realisations of this shard out of `r` per condition.
    pub fn range(&self, r: u64) -> std::ops::Range<u64> {
        let at = |k: u64| (u128::from(k) * u128::from(r) / u128::from(self.count)) as u64;
        at(self.index)..at(self.index + 1)
    }

    /// Directory of this shard inside the output directory (`shard=K`, hive style).
    pub fn dir_name(&self) -> String {
        format!("shard={}", self.index)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}
