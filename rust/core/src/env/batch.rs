//! A batch of episodes stepped together: one call steps every episode on `threads` workers
//! (the calling thread and helpers kept for the batch's life, episodes handed out one at a
//! time), with automatic resets.
//!
//! Episode `i` of a batch behaves exactly like a lone [`Episode`] built and reset with the
//! same seeds: the batch only schedules them.

use super::action::check_action;
use super::episode::{Episode, EpisodeConfig, EpisodeSummary, Site, StepReport};
use super::pool::Pool;
use crate::error::{Error, Result};
use crate::math::Real;

/// When an ended episode starts again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AutoReset {
    /// The step after the last one resets instead of stepping (its report is all zeros;
    /// Gymnasium's `NEXT_STEP`).
    NextStep,
    /// The last step resets at once; its observation is the new episode's first, the last
    /// one is kept in `final_obs` (Gymnasium's `SAME_STEP`, SB3's `terminal_observation`).
    SameStep,
}

impl AutoReset {
    /// Parses `"next_step"` or `"same_step"`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "next_step" => Ok(Self::NextStep),
            "same_step" => Ok(Self::SameStep),
            other => Err(Error::invalid("autoreset_mode", format!("expected \"next_step\" or \"same_step\", got {other:?}"))),
        }
    }
}

/// What happened to one episode of the batch in one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SlotOutcome {
    /// The step's report (all zeros for a `NextStep` reset).
    pub report: StepReport,
    /// The episode was reset in this call (`NextStep`: instead of stepping; `SameStep`: after
    /// its last step).
    pub reset: bool,
    /// The totals of the episode that ended in this call.
    pub ended: Option<EpisodeSummary>,
}

/// N episodes of one site source and configuration.
#[derive(Debug)]
pub struct Batch {
    episodes: Vec<Episode>,
    mode: AutoReset,
    /// The workers (the calling thread and `threads − 1` helpers).
    pool: Pool,
    needs_reset: Vec<bool>,
    obs_len: usize,
}

impl Batch {
    /// Builds `seeds.len()` episodes, episode `i` reset with `seeds[i]`.
    pub fn new(site: Site, config: EpisodeConfig, seeds: &[u64], mode: AutoReset, threads: usize) -> Result<Self> {
        if seeds.is_empty() {
            return Err(Error::invalid("num_envs", "must be at least 1"));
        }
        let pool = Pool::new(threads)?;
        let mut slots: Vec<Option<Episode>> = (0..seeds.len()).map(|_| None).collect();
        pool.run(&mut slots, |slot, i| {
            *slot = Some(Episode::new(site.clone(), config.clone(), seeds[i])?);
            Ok(())
        })?;
        let episodes: Vec<Episode> = slots.into_iter().map(|e| e.expect("every slot is built")).collect();
        let obs_len = episodes[0].observation_len();
        Ok(Self { needs_reset: vec![false; episodes.len()], episodes, mode, pool, obs_len })
    }

    /// Number of episodes.
    pub fn len(&self) -> usize {
        self.episodes.len()
    }

    /// Never empty.
    pub fn is_empty(&self) -> bool {
        self.episodes.is_empty()
    }

    /// Length of one flat observation.
    pub fn observation_len(&self) -> usize {
        self.obs_len
    }

    /// The episodes.
    pub fn episodes(&self) -> &[Episode] {
        &self.episodes
    }

    fn check_len(&self, name: &'static str, got: usize, per: usize) -> Result<()> {
        if got != self.len() * per {
            return Err(Error::DimensionMismatch { name, expected: self.len() * per, got });
        }
        Ok(())
    }

    /// Resets every episode, episode `i` with `seeds[i]`; writes the observations (N × L).
    pub fn reset(&mut self, seeds: &[u64], obs: &mut [f32]) -> Result<()> {
        self.check_len("seeds", seeds.len(), 1)?;
        self.check_len("observations", obs.len(), self.obs_len)?;
        let l = self.obs_len;
        let mut work: Vec<(&mut Episode, &mut [f32])> = self.episodes.iter_mut().zip(obs.chunks_mut(l)).collect();
        self.pool.run(&mut work, |(ep, o), i| {
            ep.reset(seeds[i])?;
            ep.observe(o)
        })?;
        self.needs_reset.iter_mut().for_each(|r| *r = false);
        Ok(())
    }

    /// Steps every episode with its row of `actions` (N × 3); an episode that resets uses its
    /// entry of `next_seeds`. Writes the observations (N × L), the last observation of
    /// episodes that ended in this call (`final_obs`, N × L, `SameStep` only) and one outcome
    /// per episode.
    ///
    /// Every row that will be stepped (not those of episodes about to reset) is checked
    /// first: a bad row is an error naming it (`actions[2]`) and no episode is stepped.
    pub fn step(&mut self, actions: &[Real], next_seeds: &[u64], obs: &mut [f32], final_obs: &mut [f32], out: &mut [SlotOutcome]) -> Result<()> {
        self.check_len("actions", actions.len(), 3)?;
        self.check_len("next_seeds", next_seeds.len(), 1)?;
        self.check_len("observations", obs.len(), self.obs_len)?;
        self.check_len("final_observations", final_obs.len(), self.obs_len)?;
        self.check_len("outcomes", out.len(), 1)?;
        for (i, &nr) in self.needs_reset.iter().enumerate() {
            if nr {
                continue;
            }
            let a = [actions[3 * i], actions[3 * i + 1], actions[3 * i + 2]];
            if check_action(&a).is_err() {
                return Err(Error::invalid("actions", format!("actions[{i}]: every entry must be finite and in [-1, 1], got {a:?}; no episode was stepped")));
            }
        }
        let (l, mode) = (self.obs_len, self.mode);
        type Work<'a> = (&'a mut Episode, &'a mut bool, &'a mut [f32], &'a mut [f32], &'a mut SlotOutcome);
        let mut work: Vec<Work<'_>> = self
            .episodes
            .iter_mut()
            .zip(self.needs_reset.iter_mut())
            .zip(obs.chunks_mut(l).zip(final_obs.chunks_mut(l)))
            .zip(out.iter_mut())
            .map(|(((ep, nr), (o, f)), s)| (ep, nr, o, f, s))
            .collect();
        self.pool.run(&mut work, |(ep, needs_reset, o, f, slot), i| {
            if **needs_reset {
                ep.reset(next_seeds[i])?;
                **slot = SlotOutcome { report: StepReport::default(), reset: true, ended: None };
                **needs_reset = false;
                return ep.observe(o);
            }
            let a = [actions[3 * i], actions[3 * i + 1], actions[3 * i + 2]];
            let report = ep.step(a)?;
            ep.observe(o)?;
            **slot = SlotOutcome { report, reset: false, ended: None };
            if report.terminated || report.truncated {
                slot.ended = Some(*ep.summary());
                match mode {
                    AutoReset::NextStep => **needs_reset = true,
                    AutoReset::SameStep => {
                        f.copy_from_slice(o);
                        ep.reset(next_seeds[i])?;
                        ep.observe(o)?;
                        slot.reset = true;
                    }
                }
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without the wall-clock fields.
    fn timeless(r: StepReport) -> StepReport {
        StepReport { solve_time_ns: 0, ..r }
    }

    fn timeless_summary(s: EpisodeSummary) -> EpisodeSummary {
        EpisodeSummary { solve_time_mean_ns: 0.0, solve_time_max_ns: 0, ..s }
    }

    fn actions(n: usize, k: usize) -> Vec<Real> {
        (0..n).flat_map(|i| [((k + i) as Real * 0.37).sin(), ((k * 3 + i) as Real * 0.21).cos() * 0.5, 0.2]).collect()
    }

    #[test]
    fn a_batch_equals_lone_episodes_bit_for_bit_across_resets() {
        let cfg = EpisodeConfig { time_limit: Some(40), ..Default::default() };
        let site = Site::Preset("dynamic_obstacles".into());
        let seeds = [5u64, 6, 7];
        let mut batch = Batch::new(site.clone(), cfg.clone(), &seeds, AutoReset::SameStep, 2).unwrap();
        let mut lone: Vec<Episode> = seeds.iter().map(|&s| Episode::new(site.clone(), cfg.clone(), s).unwrap()).collect();
        let l = batch.observation_len();
        let (mut obs, mut fin, mut out) = (vec![0f32; 3 * l], vec![0f32; 3 * l], vec![SlotOutcome::default(); 3]);
        let mut want = vec![0f32; l];
        for k in 0..100 {
            let a = actions(3, k);
            let next: Vec<u64> = (0..3).map(|i| 1000 + (k * 3 + i) as u64).collect();
            batch.step(&a, &next, &mut obs, &mut fin, &mut out).unwrap();
            for (i, ep) in lone.iter_mut().enumerate() {
                let r = ep.step([a[3 * i], a[3 * i + 1], a[3 * i + 2]]).unwrap();
                assert_eq!(timeless(out[i].report), timeless(r), "step {k} env {i}");
                if r.terminated || r.truncated {
                    ep.observe(&mut want).unwrap();
                    assert_eq!(&fin[i * l..(i + 1) * l], &want[..]);
                    // (Debug text: `deadlock_time` is NaN when there was none)
                    assert_eq!(format!("{:?}", timeless_summary(out[i].ended.unwrap())), format!("{:?}", timeless_summary(*ep.summary())));
                    ep.reset(next[i]).unwrap();
                }
                ep.observe(&mut want).unwrap();
                assert_eq!(&obs[i * l..(i + 1) * l], &want[..], "step {k} env {i}");
            }
        }
    }

    #[test]
    fn next_step_mode_resets_on_the_call_after_the_end() {
        let cfg = EpisodeConfig { time_limit: Some(3), ..Default::default() };
        let mut b = Batch::new(Site::Preset("constricted_passage".into()), cfg, &[1], AutoReset::NextStep, 1).unwrap();
        let l = b.observation_len();
        let (mut obs, mut fin, mut out) = (vec![0f32; l], vec![0f32; l], vec![SlotOutcome::default()]);
        for k in 0..3 {
            b.step(&[0.5, 0.0, 0.0], &[9], &mut obs, &mut fin, &mut out).unwrap();
            assert_eq!(out[0].report.truncated, k == 2);
            assert_eq!(out[0].ended.map(|e| e.steps), (k == 2).then_some(3));
            assert!(!out[0].reset);
        }
        b.step(&[0.5, 0.0, 0.0], &[9], &mut obs, &mut fin, &mut out).unwrap();
        assert!(out[0].reset && out[0].report.reward == 0.0 && out[0].ended.is_none());
        assert_eq!(b.episodes()[0].seed(), 9);
    }

    #[test]
    fn wrong_lengths_are_named_errors() {
        let mut b = Batch::new(Site::Preset("constricted_passage".into()), EpisodeConfig::default(), &[1, 2], AutoReset::NextStep, 2).unwrap();
        let l = b.observation_len();
        let (mut obs, mut fin, mut out) = (vec![0f32; 2 * l], vec![0f32; 2 * l], vec![SlotOutcome::default(); 2]);
        let e = b.step(&[0.0; 3], &[1, 2], &mut obs, &mut fin, &mut out).unwrap_err();
        assert!(e.to_string().contains("actions"), "{e}");
        assert!(Batch::new(Site::Preset("constricted_passage".into()), EpisodeConfig::default(), &[], AutoReset::NextStep, 1).is_err());
    }

    #[test]
    fn a_bad_row_steps_no_episode_and_is_named() {
        let cfg = EpisodeConfig { time_limit: Some(2), ..Default::default() };
        let mut b = Batch::new(Site::Preset("constricted_passage".into()), cfg, &[1, 2, 3, 4], AutoReset::NextStep, 2).unwrap();
        let l = b.observation_len();
        let (mut obs, mut fin, mut out) = (vec![0f32; 4 * l], vec![0f32; 4 * l], vec![SlotOutcome::default(); 4]);
        let good = actions(4, 0);
        b.step(&good, &[5, 6, 7, 8], &mut obs, &mut fin, &mut out).unwrap();
        let steps = |b: &Batch| b.episodes().iter().map(|e| e.summary().steps).collect::<Vec<_>>();
        let before = steps(&b);
        for bad in [Real::NAN, 1.5, Real::INFINITY] {
            let mut a = good.clone();
            a[3 * 2 + 1] = bad;
            let e = b.step(&a, &[5, 6, 7, 8], &mut obs, &mut fin, &mut out).unwrap_err();
            assert!(e.to_string().contains("actions[2]"), "{e}");
            assert_eq!(steps(&b), before, "a refused step stepped some episode");
        }
        // the last step ends every episode; on the next call (NextStep) they reset, so their
        // rows are not read and a NaN there is no error
        b.step(&good, &[5, 6, 7, 8], &mut obs, &mut fin, &mut out).unwrap();
        assert!(out.iter().all(|o| o.ended.is_some()));
        let nan = vec![Real::NAN; 12];
        b.step(&nan, &[5, 6, 7, 8], &mut obs, &mut fin, &mut out).unwrap();
        assert!(out.iter().all(|o| o.reset));
    }
}
