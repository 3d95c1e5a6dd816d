//! Options shared by the planning commands (`serve`, `solve`): the scene, the seed and the
//! tree parameters, and how the operator's input drives sampling; with the checks that turn
//! them into a [`PlannerParams`].

use anyhow::{Context, bail};
use clap::Args;
use planner_core::{PlannerParams, Scene};

/// Options shared by every planning command.
#[derive(Debug, Args, Clone)]
pub struct CoreArgs {
    /// Scene: a built-in name (`wall-hole` alias `default`, `maze`, `tunnels`,
    /// `tunnels-1axis`, `tunnels-2axes`, `crossing-planes`, `silencer`, `bug-trap`,
    /// `roll-slot-window`, `twist-windows`, `free`; see `planner scenes`) or a TOML scene
    /// file.
    #[arg(long, default_value = "wall-hole")]
    pub scene: String,
    /// RNG seed: the same seed and inputs give the same trees.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Extension step, weighted m (I-RRT eq. 2 metric: 1 per m, 0.01 per rad²).
    #[arg(long, default_value_t = 0.05)]
    pub step: f64,
    /// Edge validation resolution, weighted m.
    #[arg(long, default_value_t = 0.005)]
    pub edge_resolution: f64,
    /// Edge validation: `discrete` (configurations every --edge-resolution) or
    /// `certified` (those, then a proof from clearances that no configuration between
    /// them collides: a solved path is free everywhere).
    #[arg(long, default_value = "certified", value_parser = ["discrete", "certified"])]
    pub edges: String,
    /// p: nearest nodes in F_a's barycenter (I-RRT uses 5).
    #[arg(long, default_value_t = 5)]
    pub neighbours: usize,
    /// Tree algorithm: `rrt-connect` (two trees, greedy I-RRT Extend) or `rrt` (one tree,
    /// one step per iteration, 5 % goal bias).
    #[arg(long, default_value = "rrt-connect", value_parser = ["rrt-connect", "rrt"])]
    pub algorithm: String,
    /// Random shortcut attempts on the solution path (0 keeps the raw tree path).
    #[arg(long, default_value_t = 100)]
    pub shortcut_attempts: u32,
    /// Touch retraction: the operator's configuration in collision no deeper than this (mm,
    /// e.g. 1, the loop's voxel) is pushed out along the contact normal to a free
    /// configuration and used instead of lost (the poses an operator passes a slot with
    /// touch its walls); 0, the default, turns it off.
    #[arg(long, default_value_t = 0.0)]
    pub touch_depth_mm: f64,
    /// RRT-Connect: how the tree extended towards the sample grows, `greedy` (I-RRT
    /// Extend: steps until reached or blocked) or `step` (one step, as OMPL's
    /// RRTConnect); the other tree always connects greedily.
    #[arg(long, default_value = "greedy", value_parser = ["greedy", "step"])]
    pub extend: String,
    /// Machine (operator-free) samples: `uniform`, or `bridge-test` (the bridge test of Hsu et
    /// al. 2003 for narrow passages, one sample in --bridge-test-share; uniform otherwise).
    #[arg(long, default_value = "uniform", value_parser = ["uniform", "bridge-test"])]
    pub machine_sampler: String,
    /// Share of bridge-test samples among machine samples, in [0, 1].
    #[arg(long, default_value_t = 0.5)]
    pub bridge_test_share: f64,
    /// σ of the bridge test's second end around the first, weighted m (m, or rad × 0.1).
    #[arg(long, default_value_t = 0.01)]
    pub bridge_test_sigma: f64,
    /// Share of machine samples (and of bridge tests' first ends) turned square to an
    /// obstacle's faces instead of uniformly (obstacle-based RRT's alignment), in [0, 1];
    /// for passages narrow in orientation, e.g. `--scene bug-trap`.
    #[arg(long, default_value_t = 0.0)]
    pub aligned_share: f64,
    /// σ of the jitter around an aligned orientation, rad per axis.
    #[arg(long, default_value_t = 0.02)]
    pub aligned_jitter_rad: f64,
    /// How the distance (used for nearest nodes, steps and edge resolution) combines
    /// translation and rotation: `euclidean` (I-RRT eq. 2, √(|Δp|² + (0.1 m·θ)²)) or
    /// `sum` (|Δp| + 0.1 m·θ, as OMPL's SE(2)/SE(3) spaces).
    #[arg(long, default_value = "euclidean", value_parser = ["euclidean", "sum"])]
    pub metric: String,
}

impl CoreArgs {
    /// Loads the scene and validates the tree parameters.
    pub fn load(&self) -> anyhow::Result<(Scene, PlannerParams)> {
        let scene = load_scene(&self.scene)?;
        let params = PlannerParams {
            step: self.step,
            edge_resolution: self.edge_resolution,
            edge_check: planner_core::EdgeCheck::parse(&self.edges)
                .with_context(|| format!("--edges: unknown `{}`", self.edges))?,
            neighbours: self.neighbours,
            algorithm: if self.algorithm == "rrt" {
                planner_core::Algorithm::Rrt
            } else {
                planner_core::Algorithm::RrtConnect
            },
            shortcut_attempts: self.shortcut_attempts,
            touch_depth_m: self.touch_depth_mm * 1e-3,
            machine_sampler: planner_core::MachineSampler::parse(
                &self.machine_sampler,
                self.bridge_test_share,
                self.bridge_test_sigma,
            )
            .with_context(|| format!("--machine-sampler: unknown `{}`", self.machine_sampler))?,
            aligned_share: self.aligned_share,
            aligned_jitter_rad: self.aligned_jitter_rad,
            extend_a: if self.extend == "step" {
                planner_core::ExtendA::Step
            } else {
                planner_core::ExtendA::Greedy
            },
            weights: planner_core::Weights {
                combine: if self.metric == "sum" {
                    planner_core::Combine::Sum
                } else {
                    planner_core::Combine::Euclidean
                },
                ..planner_core::Weights::default()
            },
            ..PlannerParams::default()
        };
        params.validate()?;
        Ok((scene, params))
    }
}

/// The portfolio of narrow-passage methods ([`planner_core::portfolio`]).
#[derive(Debug, Args, Clone)]
pub struct PortfolioArgs {
    /// Narrow-passage methods that take turns in the planner, time shared by what each
    /// gives per collision check: a comma list of `uniform`, `bridge-test`, `aligned`,
    /// `thinning` (machine samples uniform, by the bridge test, square to an obstacle;
    /// small-step retraction seeded by the operator), `all` for the four, or `off` (one
    /// planner with --machine-sampler and --aligned-share).
    #[arg(long, value_name = "METHODS")]
    pub portfolio: Option<String>,
    /// Least share of the checks each method of --portfolio gets, in [0, 1/methods).
    #[arg(long, default_value_t = 0.2)]
    pub portfolio_floor: f64,
    /// Collision checks of one thinning turn of --portfolio.
    #[arg(long, default_value_t = 500)]
    pub portfolio_slice_checks: u64,
    /// Object scale of the first thinning stage of --portfolio, in (0, 1); the stages
    /// grow by --portfolio-thinning-step to the real object.
    #[arg(long, default_value_t = 0.45)]
    pub portfolio_thinning: f64,
    /// Scale step between the thinning stages of --portfolio, in (0, 1).
    #[arg(long, default_value_t = 0.05)]
    pub portfolio_thinning_step: f64,
    /// Reward of a node a machine sample added, in --portfolio's sharing (new ground
    /// earns 1).
    #[arg(long, default_value_t = 0.1)]
    pub portfolio_node_reward: f64,
    /// Authority of --portfolio's thinned plan over the operator's samples (H-RRT-C):
    /// `same` as --authority, or `adaptive` (the machine takes a growing share while the
    /// operator makes no progress; with --authority-patience-s, --authority-ramp-s and
    /// --authority-max-machine where the command has them).
    #[arg(long, default_value = "same", value_parser = ["same", "adaptive"])]
    pub portfolio_thinning_authority: String,
}

impl PortfolioArgs {
    /// The portfolio asked for, `default` (a --portfolio value) when none is; `None` when
    /// off. `adaptive` is the adaptive authority's parameters, for
    /// --portfolio-thinning-authority adaptive.
    pub fn params(
        &self,
        default: &str,
        adaptive: planner_core::AdaptiveAuthority,
    ) -> anyhow::Result<Option<planner_core::portfolio::PortfolioParams>> {
        use planner_core::portfolio::{Method, PortfolioParams};
        let list = self.portfolio.as_deref().unwrap_or(default);
        let methods = match list {
            "off" => return Ok(None),
            "all" => Method::ALL.to_vec(),
            list => list
                .split(',')
                .map(|m| {
                    Method::parse(m.trim()).with_context(|| {
                        format!(
                            "--portfolio {list}: unknown method `{m}` (uniform, bridge-test, aligned, thinning, all or off)"
                        )
                    })
                })
                .collect::<anyhow::Result<_>>()?,
        };
        let p = PortfolioParams {
            methods,
            floor: self.portfolio_floor,
            slice_checks: self.portfolio_slice_checks,
            thinning: planner_core::retraction::ThinningParams::from_first(
                self.portfolio_thinning,
                self.portfolio_thinning_step,
            )
            .context("--portfolio-thinning / --portfolio-thinning-step")?,
            node_reward: self.portfolio_node_reward,
            thinning_authority: (self.portfolio_thinning_authority == "adaptive")
                .then_some(planner_core::Authority::Adaptive(adaptive)),
            ..PortfolioParams::default()
        };
        p.validate().context("--portfolio")?;
        Ok(Some(p))
    }
}

/// Operator-driven sampling options (I-RRT §4.2.2 and §6, H-RRT-C Algorithms 1–2).
#[derive(Debug, Args, Clone)]
pub struct SamplingArgs {
    /// Sampling method: `cs` (uniform), `pos` (Gaussian around the operator along F_r),
    /// `path` (Gaussian around the operator's travelled path), `pos+cs` / `path+cs` (one
    /// uniform sample in β), `hrrtc` (H-RRT-C: uniform with probability α else the
    /// operator's configuration; HapticSampling on the contact plane while in contact).
    #[arg(long, default_value = "hrrtc",
          value_parser = ["cs", "pos", "path", "pos+cs", "path+cs", "hrrtc"])]
    pub sampling: String,
    /// α of H-RRT-C: share of machine (uniform) samples in free space, in [0, 1] (with
    /// `--authority adaptive`: while the operator progresses).
    #[arg(long, default_value_t = 0.5)]
    pub alpha: f64,
    /// H-RRT-C's authority sharing: `fixed` (the paper's α: in contact only contact
    /// samples, in free space α machine samples, whatever the operator does) or `adaptive`
    /// (α machine samples while the operator progresses, in free space and in contact
    /// alike; after --authority-patience-s without progress the machine share rises over
    /// --authority-ramp-s to --authority-max-machine; back at once when the operator
    /// progresses again) [default: fixed].
    #[arg(long, value_parser = ["fixed", "adaptive"])]
    pub authority: Option<String>,
    /// Adaptive authority: seconds without progress (towards the goal, on new ground, or
    /// samples that open new ground for the trees) before the operator's share falls.
    #[arg(long, default_value_t = 0.5)]
    pub authority_patience_s: f64,
    /// Adaptive authority: seconds over which the machine share then rises to its cap.
    #[arg(long, default_value_t = 0.5)]
    pub authority_ramp_s: f64,
    /// Adaptive authority: the machine share of a stuck operator, in [0, 1] (1: every
    /// sample is the machine's).
    #[arg(long, default_value_t = 1.0)]
    pub authority_max_machine: f64,
    /// β of the +CS methods: one sample in β is uniform (I-RRT uses 3), >= 1.
    #[arg(long, default_value_t = 3.0)]
    pub beta: f64,
    /// σ: standard deviation of the POS and PATH Gaussians, weighted m (m, or rad × 0.1).
    #[arg(long, default_value_t = 0.05)]
    pub sigma: f64,
    /// α of I-RRT eq. 1, F_r = α·F_u + (1−α)·F_a, in [0, 1].
    #[arg(long, default_value_t = 0.5)]
    pub fr_alpha: f64,
    /// Grow I-RRT local trees at operator and bridge samples the main trees cannot reach.
    #[arg(long)]
    pub local_trees: bool,
    /// H-RRT-C in contact: `paper` (Algorithm 2: only HapticSampling while the operator is
    /// in contact) or `shared` (a share α of machine samples in contact too, as in free
    /// space).
    #[arg(long, default_value = "paper", value_parser = ["paper", "shared"])]
    pub contact_authority: String,
    /// H-RRT-C's human mode: `fresh` (q_device when it moved since the last one sampled,
    /// else a PATH sample near the operator's travelled path, so a still operator keeps
    /// helping) or `every` (q_device at every human-mode sample, as the paper writes
    /// Algorithm 2).
    #[arg(long, default_value = "fresh", value_parser = ["fresh", "every"])]
    pub human_mode: String,
}

impl SamplingArgs {
    /// Applies the options to `params` and validates them.
    pub fn apply(&self, params: &mut PlannerParams) -> anyhow::Result<()> {
        params.sampling = planner_core::Sampling::parse(&self.sampling, self.beta, self.alpha)
            .with_context(|| format!("unknown --sampling {}", self.sampling))?;
        params.user_sigma = self.sigma;
        params.fr_alpha = self.fr_alpha;
        params.contact.shared_authority = self.contact_authority == "shared";
        params.human_mode = if self.human_mode == "every" {
            planner_core::HumanMode::Every
        } else {
            planner_core::HumanMode::Fresh
        };
        params.local_trees = self.local_trees;
        params.authority = self.authority(params.sampling)?;
        params.validate()?;
        Ok(())
    }

    /// `--authority` and its parameters, checked; an adaptive authority only for H-RRT-C.
    fn authority(
        &self,
        sampling: planner_core::Sampling,
    ) -> anyhow::Result<planner_core::Authority> {
        let hrrtc = matches!(sampling, planner_core::Sampling::Hrrtc { .. });
        let name = match self.authority.as_deref() {
            Some(name) => name,
            None => DEFAULT_AUTHORITY,
        };
        if name == "fixed" || (!hrrtc && self.authority.is_none()) {
            return Ok(planner_core::Authority::Fixed);
        }
        if !hrrtc {
            bail!(
                "--authority {name}: authority sharing is H-RRT-C's (--sampling hrrtc), not --sampling {}",
                self.sampling
            );
        }
        Ok(planner_core::Authority::Adaptive(
            self.adaptive_authority()?,
        ))
    }

    /// The adaptive authority's parameters from --authority-patience-s, --authority-ramp-s
    /// and --authority-max-machine, checked (for --authority adaptive and
    /// --portfolio-thinning-authority adaptive alike).
    pub fn adaptive_authority(&self) -> anyhow::Result<planner_core::AdaptiveAuthority> {
        let max = self.authority_max_machine;
        if !(0.0..=1.0).contains(&max) {
            bail!("--authority-max-machine must be in [0, 1], got {max}");
        }
        Ok(planner_core::AdaptiveAuthority {
            patience_s: positive("authority-patience-s", self.authority_patience_s)?,
            ramp_s: positive("authority-ramp-s", self.authority_ramp_s)?,
            max_machine_share: max,
            ..planner_core::AdaptiveAuthority::default()
        })
    }
}

/// H-RRT-C's authority when `--authority` is not given.
pub const DEFAULT_AUTHORITY: &str = "fixed";

/// `v` if it is finite and > 0; the error names the flag `--name`.
pub fn positive(name: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        bail!("--{name} must be a finite number > 0, got {v}")
    }
}

/// `v` if it is finite and >= 0; the error names the flag `--name`.
pub fn non_negative(name: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        bail!("--{name} must be a finite number >= 0, got {v}")
    }
}

/// `Some(positive(v))` for a given optional value.
pub fn positive_opt(name: &str, v: Option<f64>) -> anyhow::Result<Option<f64>> {
    v.map(|d| positive(name, d)).transpose()
}

/// The scene `arg` (a built-in name or a file) with its meshes' repairs logged; reading a
/// big mesh shows how long it has been at it (a line on a terminal, log lines otherwise).
pub fn load_scene(arg: &str) -> anyhow::Result<Scene> {
    let scene = scene::progress::showing(&format!("reading scene {arg}"), || {
        Scene::by_name_or_path(arg)
    })?;
    log_mesh_repairs(&scene);
    Ok(scene)
}

/// One log line per mesh part that loading repaired, left open or refused.
pub fn log_mesh_repairs(scene: &Scene) {
    for (warning, line) in scene.mesh_notes() {
        if warning {
            tracing::warn!("{line}");
        } else {
            tracing::info!("{line}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        sampling: SamplingArgs,
        #[command(flatten)]
        portfolio: PortfolioArgs,
    }

    fn apply(args: &[&str]) -> anyhow::Result<PlannerParams> {
        let cli = Cli::try_parse_from(std::iter::once("t").chain(args.iter().copied()))?;
        let mut params = PlannerParams::default();
        cli.sampling.apply(&mut params)?;
        Ok(params)
    }

    #[test]
    fn authority_flags_become_params_and_bad_ones_are_named() {
        let p = apply(&["--authority", "adaptive", "--authority-ramp-s", "2"]).unwrap();
        match p.authority {
            planner_core::Authority::Adaptive(a) => {
                assert_eq!(
                    (a.patience_s, a.ramp_s, a.max_machine_share),
                    (0.5, 2.0, 1.0)
                )
            }
            other => panic!("{other:?}"),
        }
        let p = apply(&["--authority", "fixed", "--alpha", "0.2"]).unwrap();
        assert_eq!(p.authority, planner_core::Authority::Fixed);
        assert_eq!(p.sampling, planner_core::Sampling::Hrrtc { alpha: 0.2 });
        // Automatic planning has no authority to share: fixed, unless asked otherwise.
        let p = apply(&["--sampling", "cs"]).unwrap();
        assert_eq!(p.authority, planner_core::Authority::Fixed);
        let e = apply(&["--sampling", "cs", "--authority", "adaptive"]).unwrap_err();
        assert!(e.to_string().contains("--authority adaptive"), "{e}");
        for (flag, v) in [
            ("--authority-patience-s", "0"),
            ("--authority-ramp-s", "nan"),
            ("--authority-max-machine", "1.5"),
        ] {
            let e = apply(&["--authority", "adaptive", flag, v]).unwrap_err();
            assert!(e.to_string().contains(&flag[2..]), "{flag}: {e}");
        }
        let e = apply(&["--authority", "sometimes"]).unwrap_err();
        assert!(e.to_string().contains("--authority"), "{e}");
    }

    #[test]
    fn the_thinned_plans_adaptive_authority_takes_the_authority_flags() {
        let cli = Cli::try_parse_from([
            "t",
            "--portfolio-thinning-authority",
            "adaptive",
            "--authority-patience-s",
            "2",
            "--authority-max-machine",
            "0.8",
        ])
        .unwrap();
        let adaptive = cli.sampling.adaptive_authority().unwrap();
        let p = cli.portfolio.params("all", adaptive).unwrap().unwrap();
        match p.thinning_authority {
            Some(planner_core::Authority::Adaptive(a)) => {
                assert_eq!(
                    (a.patience_s, a.ramp_s, a.max_machine_share),
                    (2.0, 0.5, 0.8)
                )
            }
            other => panic!("{other:?}"),
        }
        // `same` leaves the thinned plan with the main planner's authority.
        let cli = Cli::try_parse_from(["t", "--authority-patience-s", "2"]).unwrap();
        let adaptive = cli.sampling.adaptive_authority().unwrap();
        let p = cli.portfolio.params("all", adaptive).unwrap().unwrap();
        assert_eq!(p.thinning_authority, None);
    }
}

/// The planner's memory bound (`planner solve`, `planner serve`).
#[derive(Debug, Args, Clone)]
pub struct MemoryArgs {
    /// Keep the planner's heap under this many MiB: past three quarters of it, the planner
    /// drops what is worth least (stale local trees, then tree leaves that sampling never
    /// chose) and plans on. Default: a quarter of the machine's memory, at most 4096, at
    /// least 256, and under four fifths of a cgroup limit (systemd's MemoryMax).
    #[arg(long, value_name = "MB")]
    pub max_memory_mb: Option<u64>,
}

impl MemoryArgs {
    /// The bound, read by the planner's heap meter.
    pub fn bound(&self) -> anyhow::Result<planner_core::memory::MemoryBound> {
        let mb = self
            .max_memory_mb
            .unwrap_or_else(crate::heap::default_bound_mb);
        if mb == 0 || mb > 1 << 30 {
            bail!("--max-memory-mb must be within [1, 2^30], got {mb}");
        }
        Ok(planner_core::memory::MemoryBound {
            bound_bytes: usize::try_from(mb << 20).context("--max-memory-mb: too large")?,
            live_bytes: crate::heap::live_bytes,
            peak_bytes: crate::heap::peak_bytes,
        })
    }
}

/// One line on what a bounded run's heap did.
pub fn memory_line(m: &planner_core::memory::MemoryReport) -> String {
    const MB: f64 = (1 << 20) as f64;
    format!(
        "memory: heap peak {:.1} MiB of the {:.0} MiB bound (baseline {:.1}, end {:.1}); {}{}",
        m.peak_bytes as f64 / MB,
        m.bound_bytes as f64 / MB,
        m.baseline_bytes as f64 / MB,
        m.live_bytes as f64 / MB,
        m.dropped,
        if m.full_stops > 0 {
            "; planning stopped at the bound"
        } else {
            ""
        }
    )
}
