//! Every random stream's identifier, in one place (docs/model.md#streams).
//!
//! A stream is keyed by (seed, condition or draw group, stream identifier) with the
//! realisation as its ChaCha stream. The identifier is part of every study's numbers: never
//! change or reuse one. A new source of randomness takes the next free number here.

/// The random streams of the engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stream {
    /// Speed-measurement noise.
    Velocity = 1,
    /// Output (accelerometer) noise.
    Output = 2,
    /// Grade-measurement noise.
    Grade = 3,
    /// Propulsion-force measurement noise.
    Force = 4,
    /// The line-fit model's measurement noise.
    LineFit = 5,
    /// The truth's wind gusts, drawn per realisation.
    Gusts = 6,
    /// The truth's random force calibration, drawn per realisation.
    ForceCalibration = 7,
    /// The elevation map's error, drawn per realisation.
    GradeMap = 8,
}

impl Stream {
    /// Every stream, in the order of their identifiers.
    pub const ALL: [Stream; 8] = [
        Stream::Velocity,
        Stream::Output,
        Stream::Grade,
        Stream::Force,
        Stream::LineFit,
        Stream::Gusts,
        Stream::ForceCalibration,
        Stream::GradeMap,
    ];

    /// Its identifier: the stream's part of the ChaCha key.
    pub const fn id(self) -> u64 {
        self as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stream_has_its_own_identifier_and_all_are_listed() {
        let mut ids: Vec<u64> = Stream::ALL.iter().map(|s| s.id()).collect();
        // The identifiers the engine's numbers were pinned with (docs/model.md#streams).
        assert_eq!(ids, [1, 2, 3, 4, 5, 6, 7, 8]);
        ids.dedup();
        assert_eq!(ids.len(), Stream::ALL.len());
        // ALL lists every variant: a variant missing from it would not match here.
        for s in Stream::ALL {
            let listed = match s {
                Stream::Velocity
                | Stream::Output
                | Stream::Grade
                | Stream::Force
                | Stream::LineFit
                | Stream::Gusts
                | Stream::ForceCalibration
                | Stream::GradeMap => true,
            };
            assert!(listed);
        }
    }
}
