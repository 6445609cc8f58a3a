//! Every random stream's identifier, in one place (docs/model.md#streams).
//!
//! A stream is keyed by (seed, condition or draw group, stream identifier) with the
//! realisation as its ChaCha stream. The identifier is part of every study's numbers: never
//! change or reuse one. A new source of randomness takes a number no stream has.

/// The random streams of the engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stream {
    /// A noise channel's draws, its identifier the channel's own (its
    /// `ChannelTerms::STREAM`: 1 speed, 2 output, 3 grade, 4 force, 9 air speed; a new channel takes a
    /// number no stream has, 11 the first, which the channels' test checks).
    Channel(u64),
    /// The line-fit model's measurement noise.
    LineFit,
    /// The truth's wind gusts, drawn per realisation.
    Gusts,
    /// The truth's random force calibration, drawn per realisation.
    ForceCalibration,
    /// The elevation map's error, drawn per realisation.
    GradeMap,
    /// A truth that follows the filters' model (its mass, grade walk and process noise),
    /// drawn per realisation.
    FilterTruth,
}

impl Stream {
    /// Every stream that is not a noise channel's, in the order of their identifiers.
    pub const OTHERS: [Stream; 5] = [
        Stream::LineFit,
        Stream::Gusts,
        Stream::ForceCalibration,
        Stream::GradeMap,
        Stream::FilterTruth,
    ];

    /// Its identifier: the stream's part of the ChaCha key.
    pub const fn id(self) -> u64 {
        match self {
            Stream::Channel(id) => id,
            Stream::LineFit => 5,
            Stream::Gusts => 6,
            Stream::ForceCalibration => 7,
            Stream::GradeMap => 8,
            Stream::FilterTruth => 10,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_other_streams_keep_their_identifiers() {
        let ids: Vec<u64> = Stream::OTHERS.iter().map(|s| s.id()).collect();
        // The identifiers the engine's numbers were pinned with (docs/model.md#streams);
        // the channels' (1–4, 9) and their distinctness from these are checked with the
        // channels.
        assert_eq!(ids, [5, 6, 7, 8, 10]);
        // OTHERS lists every variant but the channels': a variant missing from it would
        // not match here.
        for s in Stream::OTHERS {
            let listed = match s {
                Stream::Channel(_) => false,
                Stream::LineFit
                | Stream::Gusts
                | Stream::ForceCalibration
                | Stream::GradeMap
                | Stream::FilterTruth => true,
            };
            assert!(listed);
        }
    }
}
