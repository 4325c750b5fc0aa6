//! The scene file's own types for the settings that belong to a stage (erosion, the
//! post-filters, the enrichment's distance rule, the blended blocks), converted to and from
//! the stages' types. The file format is defined here, in the scene, so a stage may change its
//! internals without changing what a scene file says; a change to the format is a new
//! [`super::VERSION`] with a migration in [`migrate`].
//!
//! Each module below is a `#[serde(with = ...)]` adapter for one field of [`super::Scene`].

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::{SceneError, VERSION};

/// Brings a scene file's JSON from its version up to [`VERSION`], one step per version, before
/// it is read into the typed scene. Version 1 is the first format: there is no step yet; the
/// next format change adds `1 => ...` here and a test that reads a version-1 file.
pub fn migrate(value: &mut serde_json::Value) -> Result<(), SceneError> {
    let Some(version) = value.get("version").and_then(serde_json::Value::as_u64) else {
        // No version, or not a number: the typed read names the problem.
        return Ok(());
    };
    if version == 0 {
        return Err(SceneError::Invalid {
            field: "version".into(),
            problem: format!("there is no format 0; this build reads formats 1 to {VERSION}"),
        });
    }
    if version > u64::from(VERSION) {
        return Err(SceneError::Invalid {
            field: "version".into(),
            problem: format!(
                "this scene was written by a newer Strahler (format {version}); this build reads \
                 formats 1 to {VERSION}"
            ),
        });
    }
    let mut at = version;
    while at < u64::from(VERSION) {
        // One step per format change, e.g. `1 => rename(value, "old", "new")`.
        #[allow(clippy::match_single_binding)]
        match at {
            _ => {}
        }
        at += 1;
    }
    if let Some(map) = value.as_object_mut() {
        map.insert("version".into(), VERSION.into());
    }
    Ok(())
}

/// `erosion`: the stream-power stage's settings (`crate::erosion::ErosionSettings`).
pub mod erosion {
    use super::*;
    use crate::erosion::ErosionSettings;

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    struct Erosion {
        preset: String,
        uplift_m_per_kyr: f64,
        erodibility: f64,
        m: f64,
        n: f64,
        diffusivity: f64,
        years: f64,
        steps: u32,
        talus_deg: Option<f64>,
        river_band: u32,
        roughness_m: f64,
        rock_contrast: f64,
        rock_patch_m: f64,
        strata_m: f64,
        strata_contrast: f64,
        /// Missing from older files: 0.3, the default when the field came.
        #[serde(default = "older_strength_spread")]
        strength_spread: f64,
        /// Missing from older files: 1, soft rock as strong as hard, as they eroded then.
        #[serde(default = "uniform_strength")]
        soft_rock_strength: f64,
        /// Missing from older files: uplift alike everywhere, as they eroded then.
        #[serde(default = "uniform_uplift")]
        uplift_contrast: f64,
        #[serde(default = "default_uplift_scale_m")]
        uplift_scale_m: f64,
        /// Missing from older files: the design's relief, as they eroded then.
        #[serde(default)]
        relief: crate::erosion::Relief,
        /// Missing from older files: open, as they have eroded since the outlets came.
        #[serde(default)]
        border: crate::erosion::Border,
    }

    fn older_strength_spread() -> f64 {
        0.3
    }

    fn uniform_strength() -> f64 {
        1.0
    }

    fn uniform_uplift() -> f64 {
        1.0
    }

    fn default_uplift_scale_m() -> f64 {
        crate::erosion::DEFAULT_UPLIFT_SCALE_M
    }

    impl Default for Erosion {
        fn default() -> Self {
            Self::from(&ErosionSettings::default())
        }
    }

    impl From<&ErosionSettings> for Erosion {
        fn from(e: &ErosionSettings) -> Self {
            Self {
                preset: e.preset.clone(),
                uplift_m_per_kyr: e.uplift_m_per_kyr,
                erodibility: e.erodibility,
                m: e.m,
                n: e.n,
                diffusivity: e.diffusivity,
                years: e.years,
                steps: e.steps,
                talus_deg: e.talus_deg,
                river_band: e.river_band,
                roughness_m: e.roughness_m,
                rock_contrast: e.rock_contrast,
                rock_patch_m: e.rock_patch_m,
                strata_m: e.strata_m,
                strata_contrast: e.strata_contrast,
                strength_spread: e.strength_spread,
                soft_rock_strength: e.soft_rock_strength,
                uplift_contrast: e.uplift_contrast,
                uplift_scale_m: e.uplift_scale_m,
                relief: e.relief,
                border: e.border,
            }
        }
    }

    impl From<Erosion> for ErosionSettings {
        fn from(e: Erosion) -> Self {
            Self {
                preset: e.preset,
                uplift_m_per_kyr: e.uplift_m_per_kyr,
                erodibility: e.erodibility,
                m: e.m,
                n: e.n,
                diffusivity: e.diffusivity,
                years: e.years,
                steps: e.steps,
                talus_deg: e.talus_deg,
                river_band: e.river_band,
                roughness_m: e.roughness_m,
                rock_contrast: e.rock_contrast,
                rock_patch_m: e.rock_patch_m,
                strata_m: e.strata_m,
                strata_contrast: e.strata_contrast,
                strength_spread: e.strength_spread,
                soft_rock_strength: e.soft_rock_strength,
                uplift_contrast: e.uplift_contrast,
                uplift_scale_m: e.uplift_scale_m,
                relief: e.relief,
                border: e.border,
            }
        }
    }

    pub fn serialize<S: Serializer>(
        value: &Option<ErosionSettings>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        value.as_ref().map(Erosion::from).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Option<ErosionSettings>, D::Error> {
        Ok(Option::<Erosion>::deserialize(d)?.map(ErosionSettings::from))
    }
}

/// `params.post`: the diffusion's post-filters (`crate::diffusion::PostFilter`).
pub mod post {
    use super::*;
    use crate::diffusion::PostFilter;

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    struct Post {
        smooth_sigma: f32,
        fbm_amplitude: f32,
        fbm_frequency: f32,
        fbm_octaves: u32,
        fbm_roughness: f32,
        protect: f32,
    }

    impl Default for Post {
        fn default() -> Self {
            Self::from(&PostFilter::default())
        }
    }

    impl From<&PostFilter> for Post {
        fn from(p: &PostFilter) -> Self {
            Self {
                smooth_sigma: p.smooth_sigma,
                fbm_amplitude: p.fbm_amplitude,
                fbm_frequency: p.fbm_frequency,
                fbm_octaves: p.fbm_octaves,
                fbm_roughness: p.fbm_roughness,
                protect: p.protect,
            }
        }
    }

    pub fn serialize<S: Serializer>(p: &PostFilter, s: S) -> Result<S::Ok, S::Error> {
        Post::from(p).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<PostFilter, D::Error> {
        let p = Post::deserialize(d)?;
        Ok(PostFilter {
            smooth_sigma: p.smooth_sigma,
            fbm_amplitude: p.fbm_amplitude,
            fbm_frequency: p.fbm_frequency,
            fbm_octaves: p.fbm_octaves,
            fbm_roughness: p.fbm_roughness,
            protect: p.protect,
        })
    }
}

/// `params.enrich.distance_rule`: what MD/MDI's distance limit limits
/// (`crate::skeleton::enrich::DistanceRule`).
pub mod distance_rule {
    use super::*;
    use crate::skeleton::enrich::DistanceRule;

    #[derive(Serialize, Deserialize)]
    #[serde(rename_all = "lowercase")]
    enum Rule {
        Skeleton,
        Points,
    }

    pub fn serialize<S: Serializer>(rule: &DistanceRule, s: S) -> Result<S::Ok, S::Error> {
        match rule {
            DistanceRule::Skeleton => Rule::Skeleton,
            DistanceRule::Points => Rule::Points,
        }
        .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<DistanceRule, D::Error> {
        Ok(match Rule::deserialize(d)? {
            Rule::Skeleton => DistanceRule::Skeleton,
            Rule::Points => DistanceRule::Points,
        })
    }
}

/// `blend`: the blended blocks (`crate::blend::BlendBlock`).
pub mod blocks {
    use super::*;
    use crate::blend::BlendBlock;

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Block {
        name: String,
        reference_png: String,
        rect: [f64; 4],
        #[serde(default)]
        quarter_turns: u8,
        #[serde(default)]
        mirror: bool,
        #[serde(default = "one")]
        z_scale: f32,
        /// Missing in files written before the feathered edge: 0, eq. 9 alone, so they keep
        /// their terrain.
        #[serde(default)]
        feather: f32,
    }

    fn one() -> f32 {
        1.0
    }

    pub fn serialize<S: Serializer>(blocks: &[BlendBlock], s: S) -> Result<S::Ok, S::Error> {
        let file: Vec<Block> = blocks
            .iter()
            .map(|b| Block {
                name: b.name.clone(),
                reference_png: b.reference_png.clone(),
                rect: b.rect,
                quarter_turns: b.quarter_turns,
                mirror: b.mirror,
                z_scale: b.z_scale,
                feather: b.feather,
            })
            .collect();
        file.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<BlendBlock>, D::Error> {
        Ok(Vec::<Block>::deserialize(d)?
            .into_iter()
            .map(|b| BlendBlock {
                name: b.name,
                reference_png: b.reference_png,
                rect: b.rect,
                quarter_turns: b.quarter_turns,
                mirror: b.mirror,
                z_scale: b.z_scale,
                feather: b.feather,
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{Scene, SceneError};

    fn version_error(version: &str) -> String {
        let text = format!(r#"{{"version": {version}, "rivers": []}}"#);
        match Scene::from_json(&text) {
            Err(SceneError::Invalid { field, problem }) => format!("{field}: {problem}"),
            other => panic!("{version}: {other:?}"),
        }
    }

    #[test]
    fn formats_that_do_not_exist_are_refused_by_name() {
        let newer = version_error("7");
        assert!(
            newer.starts_with("version:") && newer.contains("newer Strahler"),
            "{newer}"
        );
        let zero = version_error("0");
        assert!(zero.contains("no format 0"), "{zero}");
    }

    /// The file's schema is the scene's: every stage-owned section written and read back,
    /// with the keys a scene file has always had.
    #[test]
    fn stage_sections_keep_their_keys() {
        let mut scene = Scene::default();
        scene.params.enrich.distance_rule = crate::skeleton::enrich::DistanceRule::Points;
        scene.params.post.smooth_sigma = 1.5;
        let reference =
            crate::heightfield::Heightfield::from_vec(4, 4, (0..16).map(|v| v as f32).collect())
                .unwrap();
        let mut block =
            crate::blend::BlendBlock::new("b", &reference, [0.1, 0.1, 0.4, 0.4]).unwrap();
        block.mirror = true;
        scene.blend.push(block);
        let json = scene.to_json();
        let value: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(value["params"]["enrich"]["distance_rule"], "points");
        assert_eq!(value["params"]["post"]["smooth_sigma"], 1.5);
        assert_eq!(value["erosion"]["preset"], "young-mountains");
        assert_eq!(value["blend"][0]["mirror"], true);
        assert_eq!(Scene::from_json(&json).unwrap(), scene);
    }
}
