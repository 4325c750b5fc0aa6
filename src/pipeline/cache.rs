//! The stage cache: each stage's last output with the key it was computed for.

use std::sync::Arc;

use serde::Serialize;

use super::{Blended, Detailed, Styled};
use crate::erosion::Eroded;
use crate::terrain::Generated;

/// A stage's key: FNV-1a over the JSON of exactly the inputs the stage depends on, chained
/// from the key of the stage before it (so a change upstream invalidates everything after).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageKey(u64);

impl StageKey {
    /// The first stage's key, seeded with its name.
    pub fn start(stage: &str) -> Self {
        Self(0xcbf2_9ce4_8422_2325).mix(stage.as_bytes())
    }

    /// The next stage's key: this one, then the stage's name.
    pub fn then(self, stage: &str) -> Self {
        self.mix(b"|").mix(stage.as_bytes())
    }

    /// Adds one input. Inputs are plain data (scene sections); one that cannot be written as
    /// JSON (a non-finite number) is added by its debug form instead.
    pub fn with<T: Serialize + std::fmt::Debug + ?Sized>(self, input: &T) -> Self {
        let text = serde_json::to_string(input).unwrap_or_else(|_| format!("{input:?}"));
        self.mix(b"|").mix(text.as_bytes())
    }

    fn mix(self, bytes: &[u8]) -> Self {
        Self(bytes.iter().fold(self.0, |h, &b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        }))
    }
}

/// One stage's cached output.
#[derive(Debug)]
pub struct Cached<T>(Option<(StageKey, Arc<T>)>);

impl<T> Default for Cached<T> {
    fn default() -> Self {
        Self(None)
    }
}

impl<T> Clone for Cached<T> {
    fn clone(&self) -> Self {
        Self(self.0.clone())
    }
}

impl<T> Cached<T> {
    /// The output computed for `key`, if it is the one kept.
    pub fn get(&self, key: StageKey) -> Option<Arc<T>> {
        self.0
            .as_ref()
            .filter(|(k, _)| *k == key)
            .map(|(_, v)| v.clone())
    }

    /// Keeps `value` as the output for `key` and returns it shared.
    pub fn put(&mut self, key: StageKey, value: T) -> Arc<T> {
        let value = Arc::new(value);
        self.0 = Some((key, value.clone()));
        value
    }

    pub fn clear(&mut self) {
        self.0 = None;
    }
}

/// The cached stages of one map size.
#[derive(Clone, Debug)]
pub struct Stages {
    pub size: usize,
    pub hydrology: Cached<Generated>,
    pub erosion: Cached<Eroded>,
    pub style: Cached<Styled>,
    pub detail: Cached<Detailed>,
    pub blend: Cached<Blended>,
}

impl Stages {
    pub fn new(size: usize) -> Self {
        Self {
            size,
            hydrology: Cached::default(),
            erosion: Cached::default(),
            style: Cached::default(),
            detail: Cached::default(),
            blend: Cached::default(),
        }
    }

    /// Drops the outputs of stages the last run did not use (their memory is the largest:
    /// a detailed terrain has up to 64 times the cells of the map).
    pub fn forget_unused(&mut self, erosion: bool, style: bool, detail: bool, blend: bool) {
        if !erosion {
            self.erosion.clear();
        }
        if !style {
            self.style.clear();
        }
        if !detail {
            self.detail.clear();
        }
        if !blend {
            self.blend.clear();
        }
    }
}
