//! Sharding: line k of the manifest file (0-based, counting every line, the defaults line and
//! blank lines included) belongs to shard k mod N. The partition depends only on the file,
//! so a rerun of shard I finds the same work, whichever machine runs it.
//!
//! `--shard auto` takes the shard from the environment of the job scheduler:
//! - Slurm job arrays: `SLURM_ARRAY_TASK_ID` with `SLURM_ARRAY_TASK_COUNT`, or with
//!   `SLURM_ARRAY_TASK_MIN` / `SLURM_ARRAY_TASK_MAX` (shard = id - min, count = max - min + 1);
//!   with `--shard-count N`, shard = id of N (to resubmit some tasks of an array only);
//! - Kubernetes Indexed Jobs: `JOB_COMPLETION_INDEX` with the count from `--shard-count` or
//!   `RQR_SHARD_COUNT`;
//! - otherwise one shard, 0/1.

/// One shard of a manifest: `index` of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: u32,
    /// Number of shards.
    pub count: u32,
}

/// What `--shard` asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardSpec {
    /// `I/N`.
    Fixed(Shard),
    /// From the scheduler's environment variables.
    Auto,
}

/// A shard that cannot be used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ShardError(pub String);

impl Default for Shard {
    fn default() -> Self {
        Self { index: 0, count: 1 }
    }
}

impl Shard {
    /// A checked shard: `count >= 1`, `index < count`.
    pub fn new(index: u32, count: u32) -> Result<Self, ShardError> {
        if count == 0 {
            return Err(ShardError("the shard count must be at least 1".into()));
        }
        if index >= count {
            return Err(ShardError(format!(
                "shard {index}/{count}: the index must be below the count (shards are 0..{count})"
            )));
        }
        Ok(Self { index, count })
    }

    /// Whether 0-based manifest line `line_index` is this shard's.
    pub fn owns(&self, line_index: usize) -> bool {
        line_index as u64 % u64::from(self.count) == u64::from(self.index)
    }

    /// The results file of this shard: `results-I-of-N.jsonl`.
    pub fn results_name(&self) -> String {
        format!("results-{}-of-{}.jsonl", self.index, self.count)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for ShardSpec {
    type Err = ShardError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Self::Auto);
        }
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| ShardError(format!("--shard '{s}': expected I/N or auto")))?;
        let parse = |v: &str, what: &str| {
            v.trim()
                .parse::<u32>()
                .map_err(|e| ShardError(format!("--shard '{s}': {what} '{v}': {e}")))
        };
        Ok(Self::Fixed(Shard::new(
            parse(i, "index")?,
            parse(n, "count")?,
        )?))
    }
}

/// The environment variables [`from_env`] reads.
pub const ENV_VARS: [&str; 6] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_COUNT",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_MAX",
    "JOB_COMPLETION_INDEX",
    "RQR_SHARD_COUNT",
];

/// Resolves `--shard auto` from environment variables looked up through `env` (the process
/// environment in the CLI, a map in tests), with `shard_count` from `--shard-count`. Returns
/// the shard and where it came from.
pub fn from_env(
    env: &dyn Fn(&str) -> Option<String>,
    shard_count: Option<u32>,
) -> Result<(Shard, &'static str), ShardError> {
    let number = |name: &str| -> Result<Option<u32>, ShardError> {
        match env(name) {
            None => Ok(None),
            Some(v) if v.trim().is_empty() => Ok(None),
            Some(v) => v
                .trim()
                .parse::<u32>()
                .map(Some)
                .map_err(|e| ShardError(format!("{name}='{v}' is not a shard number: {e}"))),
        }
    };
    if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        if let Some(count) = shard_count {
            // An explicit count makes the task id the shard index, so that a subset of the
            // array (`--array=1,5`) can be resubmitted.
            return Ok((Shard::new(id, count)?, "Slurm job array, --shard-count"));
        }
        let min = number("SLURM_ARRAY_TASK_MIN")?;
        let max = number("SLURM_ARRAY_TASK_MAX")?;
        let count = number("SLURM_ARRAY_TASK_COUNT")?;
        let shard = match (min, max, count) {
            (Some(min), Some(max), _) => {
                if id < min || max < id {
                    return Err(ShardError(format!(
                        "SLURM_ARRAY_TASK_ID={id} is outside SLURM_ARRAY_TASK_MIN..=MAX ({min}..={max})"
                    )));
                }
                let n = max - min + 1;
                if let Some(c) = count.filter(|&c| c != n) {
                    return Err(ShardError(format!(
                        "SLURM_ARRAY_TASK_COUNT={c} but MIN..=MAX holds {n} tasks: rqr shards need a contiguous array without a step (--array={min}-{max})"
                    )));
                }
                Shard::new(id - min, n)?
            }
            (_, _, Some(count)) => Shard::new(id, count)?,
            _ => {
                return Err(ShardError(
                    "SLURM_ARRAY_TASK_ID is set but neither SLURM_ARRAY_TASK_COUNT nor SLURM_ARRAY_TASK_MIN/MAX is".into(),
                ))
            }
        };
        return Ok((shard, "Slurm job array"));
    }
    if let Some(index) = number("JOB_COMPLETION_INDEX")? {
        let count = match shard_count {
            Some(c) => c,
            None => number("RQR_SHARD_COUNT")?.ok_or_else(|| {
                ShardError(format!(
                    "JOB_COMPLETION_INDEX={index} is set but the shard count is not: pass --shard-count N or set RQR_SHARD_COUNT (the Job's completions)"
                ))
            })?,
        };
        return Ok((Shard::new(index, count)?, "Kubernetes Indexed Job"));
    }
    Ok((Shard::default(), "no scheduler variables: one shard"))
}

/// Resolves a [`ShardSpec`].
pub fn resolve(
    spec: ShardSpec,
    env: &dyn Fn(&str) -> Option<String>,
    shard_count: Option<u32>,
) -> Result<(Shard, &'static str), ShardError> {
    match spec {
        ShardSpec::Fixed(s) => {
            if shard_count.is_some_and(|c| c != s.count) {
                return Err(ShardError(format!(
                    "--shard {s} and --shard-count {} disagree",
                    shard_count.unwrap_or_default()
                )));
            }
            Ok((s, "--shard"))
        }
        ShardSpec::Auto => from_env(env, shard_count),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env_of(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn shards_partition_every_manifest_length() {
        for n in 1..=7u32 {
            for lines in [0usize, 1, 6, 7, 8, 50, 101] {
                let mut owner = vec![None; lines];
                for i in 0..n {
                    let shard = Shard::new(i, n).unwrap();
                    for (k, o) in owner.iter_mut().enumerate() {
                        if shard.owns(k) {
                            assert!(o.is_none(), "line {k} in shards {o:?} and {i} of {n}");
                            *o = Some(i);
                        }
                    }
                }
                assert!(owner.iter().all(Option::is_some), "N={n}, {lines} lines");
                // Balanced: shard sizes differ by at most one line.
                let sizes: Vec<usize> = (0..n)
                    .map(|i| owner.iter().filter(|o| **o == Some(i)).count())
                    .collect();
                assert!(sizes.iter().max().unwrap() - sizes.iter().min().unwrap() <= 1);
            }
        }
    }

    #[test]
    fn shard_flags_parse_and_refuse_out_of_range() {
        assert_eq!(
            "2/5".parse::<ShardSpec>(),
            Ok(ShardSpec::Fixed(Shard { index: 2, count: 5 }))
        );
        assert_eq!("auto".parse::<ShardSpec>(), Ok(ShardSpec::Auto));
        let e = "5/5".parse::<ShardSpec>().unwrap_err();
        assert!(e.0.contains("below the count"), "{e}");
        assert!("0/0".parse::<ShardSpec>().is_err());
        assert!("1-4".parse::<ShardSpec>().is_err());
        assert!("a/4".parse::<ShardSpec>().is_err());
    }

    #[test]
    fn slurm_array_variables() {
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert_eq!(
            from_env(&env, None).unwrap().0,
            Shard { index: 2, count: 4 }
        );
        // --array=10-13: ids 10..=13 are shards 0..=3.
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "12"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_MAX", "13"),
        ]);
        assert_eq!(
            from_env(&env, None).unwrap().0,
            Shard { index: 2, count: 4 }
        );
        // A stepped array (--array=0-6:2) has COUNT 4 but MIN..=MAX of 7.
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "6"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert!(from_env(&env, None).unwrap_err().0.contains("contiguous"));
        let env = env_of(&[("SLURM_ARRAY_TASK_ID", "2")]);
        assert!(from_env(&env, None).is_err());
        // Resubmitting task 5 alone (--array=5) with --shard-count 8: shard 5 of 8, not 0/1.
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "5"),
            ("SLURM_ARRAY_TASK_MAX", "5"),
            ("SLURM_ARRAY_TASK_COUNT", "1"),
        ]);
        assert_eq!(
            from_env(&env, None).unwrap().0,
            Shard { index: 0, count: 1 }
        );
        assert_eq!(
            from_env(&env, Some(8)).unwrap().0,
            Shard { index: 5, count: 8 }
        );
        assert!(from_env(&env, Some(4)).is_err());
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "x"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert!(from_env(&env, None)
            .unwrap_err()
            .0
            .contains("SLURM_ARRAY_TASK_ID='x'"));
        let env = env_of(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert!(from_env(&env, None).is_err());
    }

    #[test]
    fn kubernetes_indexed_job_variables() {
        let env = env_of(&[("JOB_COMPLETION_INDEX", "3")]);
        assert_eq!(
            from_env(&env, Some(8)).unwrap().0,
            Shard { index: 3, count: 8 }
        );
        assert!(from_env(&env, None)
            .unwrap_err()
            .0
            .contains("--shard-count"));
        let env = env_of(&[("JOB_COMPLETION_INDEX", "3"), ("RQR_SHARD_COUNT", "5")]);
        assert_eq!(
            from_env(&env, None).unwrap().0,
            Shard { index: 3, count: 5 }
        );
        // The flag wins over the variable.
        assert_eq!(
            from_env(&env, Some(4)).unwrap().0,
            Shard { index: 3, count: 4 }
        );
        assert!(from_env(&env, Some(2)).is_err());
        // Slurm wins when both are set (a Slurm job inside a pod is not an Indexed Job shard).
        let env = env_of(&[
            ("JOB_COMPLETION_INDEX", "3"),
            ("SLURM_ARRAY_TASK_ID", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
        ]);
        assert_eq!(
            from_env(&env, None).unwrap().0,
            Shard { index: 1, count: 2 }
        );
    }

    #[test]
    fn ray_and_plain_processes_are_one_shard_or_explicit() {
        // A Ray task passes --shard I/N itself; without scheduler variables auto is 0/1.
        let env = env_of(&[]);
        assert_eq!(from_env(&env, None).unwrap().0, Shard::default());
        let fixed = ShardSpec::Fixed(Shard { index: 1, count: 3 });
        assert_eq!(resolve(fixed, &env, None).unwrap().0.index, 1);
        assert!(resolve(fixed, &env, Some(4)).is_err());
    }
}
