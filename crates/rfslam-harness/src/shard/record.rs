//! What a shard's directory records about itself ([`super::SHARD_FILE`]): which shard of
//! which selection it holds, and what the merged report needs.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::assign::{Selection, Shard, ShardError};
use super::{PUBLISHED_COPY, SHARD_FILE};
use crate::error::HarnessError;
use crate::experiment::{JobFilter, Plan};

/// What the merged report needs beyond the resolved experiment.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ReportSource {
    /// The experiment's description.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The published table as the report names it; its content is in [`PUBLISHED_COPY`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub published: Option<String>,
}

/// The content of [`SHARD_FILE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardRecord {
    /// This shard's number, from 1.
    pub shard: usize,
    /// The number of shards.
    pub shards: usize,
    /// The assignment rule, in words (for the reader of the file).
    pub rule: String,
    /// Jobs of this shard.
    pub jobs: usize,
    /// Jobs of the whole (selected) sweep.
    pub sweep_jobs: usize,
    /// The `--filters` / `--particles` selection.
    #[serde(default)]
    pub selection: Selection,
    /// For the merged report.
    #[serde(default)]
    pub report: ReportSource,
}

impl ShardRecord {
    /// The record of `shard` of `plan` with selection `sel`.
    pub fn new(shard: Shard, plan: &Plan, sel: &JobFilter) -> ShardRecord {
        let all = plan.jobs(sel);
        ShardRecord {
            shard: shard.index(),
            shards: shard.count(),
            rule: format!(
                "job k (0-based) of the canonical order (grid point, filter, particles, run) of the selected jobs belongs to shard (k mod {}) + 1",
                shard.count()
            ),
            jobs: shard.select(&all).len(),
            sweep_jobs: all.len(),
            selection: Selection::of(sel),
            report: ReportSource {
                description: plan.config.description.clone(),
                published: plan.published.as_ref().map(|p| p.source.clone()),
            },
        }
    }

    /// The shard this record describes.
    pub fn shard(&self) -> Result<Shard, ShardError> {
        Shard::new(self.shard, self.shards)
    }

    /// Reads `dir/shard.toml`; `None` when there is none.
    pub fn read(dir: &Path) -> Result<Option<ShardRecord>, HarnessError> {
        let path = dir.join(SHARD_FILE);
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).map_err(|e| HarnessError::io(&path, e))?;
        let rec: ShardRecord = toml::from_str(&text).map_err(|e| {
            HarnessError::ShardMismatch(format!("{}: not a shard record: {}", path.display(), e.message()))
        })?;
        rec.shard().map_err(|e| HarnessError::ShardMismatch(format!("{}: {e}", path.display())))?;
        Ok(Some(rec))
    }

    /// Writes `dir/shard.toml`, and the published table (when the experiment names one) to
    /// `dir/published.csv`.
    pub fn write(&self, dir: &Path) -> Result<(), HarnessError> {
        let path = dir.join(SHARD_FILE);
        let body = toml::to_string_pretty(self).map_err(|e| HarnessError::write(&path, e))?;
        let text = format!(
            "# Written by `rfslam sweep --shard`: the part of the experiment this directory holds.\n# `rfslam merge` reads it with experiment.resolved.toml and runs.csv.\n{body}"
        );
        std::fs::write(&path, text).map_err(|e| HarnessError::io(&path, e))?;
        if let Some(src) = &self.report.published {
            let copy = dir.join(PUBLISHED_COPY);
            std::fs::copy(src, &copy).map_err(|e| HarnessError::io(src, e))?;
        }
        Ok(())
    }
}
