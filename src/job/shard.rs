//! A share of a job's units ([`Shard`]) and what a unit log or shard was made from
//! ([`Identity`]): the same for experiments, render tables and the irradiance protocol.

use crate::provenance::Build;

/// A deterministic share of a run's units, `index` of `count`, 1-based like cargo-nextest's
/// `--partition count:i/n`: unit `u` belongs to shard `(u mod count) + 1`. Consecutive units
/// go to different shards, so every shard gets its share of every N (and of the costly ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// All units.
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Reads `i/n` with `1 ≤ i ≤ n`; the error says what is wrong.
    pub fn parse(text: &str) -> std::result::Result<Shard, String> {
        let wrong = || format!("expected i/n with 1 <= i <= n (e.g. 1/4), got {text:?}");
        let (i, n) = text.split_once('/').ok_or_else(wrong)?;
        let (index, count): (usize, usize) = (
            i.trim().parse().map_err(|_| wrong())?,
            n.trim().parse().map_err(|_| wrong())?,
        );
        if count == 0 {
            return Err(format!("{text:?}: the number of shards must be at least 1"));
        }
        if index == 0 || index > count {
            return Err(format!("{text:?}: shards are numbered 1 to {count}"));
        }
        Ok(Shard { index, count })
    }

    /// The units of this shard among `total`, in increasing order.
    pub fn units(self, total: usize) -> impl Iterator<Item = usize> {
        (self.index - 1..total).step_by(self.count)
    }

    /// How many of `total` units this shard holds.
    pub fn len(self, total: usize) -> usize {
        total.saturating_sub(self.index - 1).div_ceil(self.count)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// What a log was made from: the job's resolved plan (as a hash, which covers the seed and the
/// number of units), the seed, how many units the whole run has, the tool's build (version,
/// commit and uncommitted changes: rows of two builds are never combined), and the share of
/// units.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    pub plan_hash: String,
    pub seed: u64,
    pub units: usize,
    pub build: Build,
    pub shard: Shard,
}

/// The header's and the shard record's key for [`Identity::units`]; logs and records written
/// before it was named (`trials`, which held the units of every job) are read as well.
pub const UNITS_KEY: &str = "units";
const OLD_UNITS_KEY: &str = "trials";

impl Identity {
    /// The log's first line.
    pub fn header(&self) -> String {
        format!(
            "# workbench unit log: plan={} seed={} {UNITS_KEY}={} version={} build={} shard={}",
            self.plan_hash,
            self.seed,
            self.units,
            self.build.version,
            self.build.token(),
            self.shard
        )
    }

    /// Reads a first line written by [`Identity::header`] (or by a build that named the units
    /// `trials`).
    pub fn from_header(line: &str) -> Option<Identity> {
        let rest = line.trim_end().strip_prefix("# workbench unit log: ")?;
        let mut fields = rest.split(' ').map(|f| f.split_once('='));
        let mut next = |keys: &[&str]| match fields.next() {
            Some(Some((k, v))) if keys.contains(&k) => Some(v.to_string()),
            _ => None,
        };
        let plan_hash = next(&["plan"])?;
        let seed = next(&["seed"])?.parse().ok()?;
        let units = next(&[UNITS_KEY, OLD_UNITS_KEY])?.parse().ok()?;
        let version = next(&["version"])?;
        let build = Build::from_token(&version, &next(&["build"])?)?;
        Some(Identity {
            plan_hash,
            seed,
            units,
            build,
            shard: Shard::parse(&next(&["shard"])?).ok()?,
        })
    }

    /// The units in a shard record ([`UNITS_KEY`], or the older `trials`).
    pub fn units_of_record(record: &serde_json::Value) -> Option<&serde_json::Value> {
        record.get(UNITS_KEY).or_else(|| record.get(OLD_UNITS_KEY))
    }

    /// One line for messages.
    pub fn describe(&self) -> String {
        format!(
            "plan {}, seed {}, {} units, workbench {}, shard {}",
            self.plan_hash,
            self.seed,
            self.units,
            self.build.describe(),
            self.shard
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_partition_the_units() {
        assert_eq!(Shard::parse("2/3"), Ok(Shard { index: 2, count: 3 }));
        for bad in ["0/3", "4/3", "1/0", "3", "a/b", "-1/3", ""] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        for count in 1..5 {
            let mut seen = vec![0; 10];
            for index in 1..=count {
                let s = Shard { index, count };
                let units: Vec<usize> = s.units(10).collect();
                assert_eq!(units.len(), s.len(10));
                for u in units {
                    seen[u] += 1;
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{count}: {seen:?}");
        }
        assert_eq!(Shard { index: 3, count: 4 }.len(2), 0);
    }

    #[test]
    fn identity_reads_back_from_its_header() {
        let id = Identity {
            plan_hash: "0123456789abcdef".into(),
            seed: 42,
            units: 300,
            build: Build {
                version: "0.1.0".into(),
                commit: Some("d9ea8fe".into()),
                changes: Some("0123456789abcdef".into()),
            },
            shard: Shard { index: 2, count: 5 },
        };
        assert_eq!(Identity::from_header(&id.header()), Some(id.clone()));
        assert_eq!(
            Identity::from_header(&format!("{}\n", id.header())),
            Some(id.clone())
        );
        assert_eq!(Identity::from_header("integrand,estimator"), None);
        // A log of a build that named the units `trials` still reads.
        let old = id.header().replace(" units=", " trials=");
        assert_ne!(old, id.header());
        assert_eq!(Identity::from_header(&old), Some(id.clone()));
        assert_eq!(
            Identity::from_header(&id.header().replace(" units=", " other=")),
            None
        );
        // Outside git, and clean.
        for (commit, changes) in [(None, None), (Some("d9ea8fe".to_string()), None)] {
            let other = Identity {
                build: Build {
                    commit,
                    changes,
                    ..id.build.clone()
                },
                ..id.clone()
            };
            assert_eq!(Identity::from_header(&other.header()), Some(other));
        }
    }
}
