//! A vehicle study's `[terrain]` table: the elevation profile and its grid, where the
//! drive mode needs or uses them, and the terrain scales (an axis of conditions).

use super::checker::Checker;
use super::checker::unknown_key;
use super::placement::{COMMON_TERRAIN_KEYS, home_of};
use super::raw::RawStudy;
use super::{MAX_SAMPLES, StudyError};
use crate::settings::Params;
use crate::terrain::profiles::PROFILES;
use crate::terrain::{ScaleTarget, TerrainSpec};

/// `[terrain]`: the profile and its grid (required when the drive mode `needs` them; read
/// when given if it `uses` them; else `[terrain]` may only give `scales`), and the scales
/// (default `[1.0]` without a profile).
pub(super) fn validate_terrain(
    raw: &RawStudy,
    needs: bool,
    uses: bool,
    c: &Checker<'_>,
) -> Result<(Option<TerrainSpec>, Vec<f64>), StudyError> {
    let t = match (&raw.terrain, needs) {
        (Some(t), _) => t,
        (None, true) => return Err(c.missing_table("terrain")),
        (None, false) => return Ok((None, vec![1.0])),
    };
    if !uses {
        if let Some(key) = t
            .params
            .keys()
            .find(|k| home_of(k).iter().any(|(t, _)| *t != "terrain"))
        {
            return Err(unknown_key(c, "terrain", key, vec!["scales"], None));
        }
        let named = [
            ("profile", t.profile.is_some()),
            ("length", t.length.is_some()),
            ("scale_applies_to", t.scale_applies_to.is_some()),
        ];
        let extra = t
            .params
            .keys()
            .map(String::as_str)
            .chain(named.iter().filter(|(_, given)| *given).map(|(k, _)| *k))
            .next();
        if let Some(key) = extra {
            return Err(c.fail(
                &format!("terrain.{key}"),
                "is not used: the trace brings its own grade (only terrain.scales is read)",
            ));
        }
        let scales = match &t.scales {
            Some(s) => c.list("terrain.scales", s, Checker::non_negative)?,
            None => vec![1.0],
        };
        return Ok((None, scales));
    }
    let required = |key: &str| c.fail(&format!("terrain.{key}"), "required key is missing");
    let name = t.profile.as_deref().ok_or_else(|| required("profile"))?;
    let entry = PROFILES.iter().find(|p| p.name == name).ok_or_else(|| {
        let names: Vec<&str> = PROFILES.iter().map(|p| p.name).collect();
        c.fail(
            "terrain.profile",
            format!("unknown profile \"{name}\"; expected one of {names:?}"),
        )
    })?;
    if let Some(key) = t.params.keys().find(|k| !entry.keys.contains(&k.as_str())) {
        let expected = COMMON_TERRAIN_KEYS.iter().chain(entry.keys);
        return Err(unknown_key(
            c,
            "terrain",
            key,
            expected.copied().collect(),
            Some(("profile", entry.name)),
        ));
    }
    let profile = (entry.parse)(&Params::new(&t.params, "terrain").relative_to(c.dir()))
        .map_err(|e| c.fail(&e.key, e.reason))?;
    let scale_applies_to = match t.scale_applies_to.as_deref() {
        Some("grade") => ScaleTarget::Grade,
        Some("elevation") => ScaleTarget::Elevation,
        Some(other) => {
            return Err(c.fail(
                "terrain.scale_applies_to",
                format!("must be \"grade\" or \"elevation\", got \"{other}\""),
            ));
        }
        None => return Err(required("scale_applies_to")),
    };
    let extent = profile.extent_m();
    let length = match (t.length, extent) {
        (Some(l), _) => l,
        (None, Some(e)) => e.floor().max(0.0) as u64,
        (None, None) => return Err(required("length")),
    };
    if length < 2 {
        return Err(c.fail(
            "terrain.length",
            format!("must be at least 2 m, got {length}"),
        ));
    }
    if length > MAX_SAMPLES as u64 {
        return Err(c.fail(
            "terrain.length",
            format!("must be at most {MAX_SAMPLES} m, got {length}"),
        ));
    }
    if let Some(e) = extent
        && length as f64 > e
    {
        return Err(c.fail(
            "terrain.length",
            format!("is {length} m but the profile's file reaches only {e} m"),
        ));
    }
    let scales = t.scales.as_ref().ok_or_else(|| required("scales"))?;
    let scales = c.list("terrain.scales", scales, Checker::non_negative)?;
    Ok((
        Some(TerrainSpec {
            profile,
            length_m: length as usize,
            scale_applies_to,
        }),
        scales,
    ))
}
