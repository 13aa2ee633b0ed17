//! Output files of `mpm-cli run`: snapshots and the `run.xmf` XDMF series, checkpoints and
//! their attributes, resuming from a checkpoint, and cleaning the outputs of an earlier run.

use super::{checkpoint_name, code_version, numbered_files, snapshot_name, Runner};
use crate::error::CliError;
use crate::files;
use crate::state::{checkpoint_state, first_non_finite, snapshot_columns, UNITS};
use mpm_core::{Dim, DimOps};
use mpm_io::Verify;
use mpm_io::{
    read_layout, write_file, write_file_with, write_xdmf_pieces, FileKind, Header, SeriesEntry,
};
use std::path::Path;
use std::time::Instant;

/// Names of checkpoint attributes.
const ATTR_FRAME: &str = "next_frame";
const ATTR_NEXT_SNAPSHOT: &str = "next_snapshot";
const ATTR_NEXT_CHECKPOINT: &str = "next_checkpoint";
/// Prefix of the checkpoint attributes holding each monitor's value at t = 0.
const ATTR_INITIAL_MONITOR: &str = "initial_monitor_";
const ATTR_INITIAL: [&str; 8] = [
    "initial_mass",
    "initial_momentum_0",
    "initial_momentum_1",
    "initial_momentum_2",
    "initial_angular_momentum_0",
    "initial_angular_momentum_1",
    "initial_angular_momentum_2",
    "initial_energy",
];
const ATTR_INITIAL_ENERGY_PARTS: [&str; 3] = [
    "initial_kinetic_energy",
    "initial_elastic_energy",
    "initial_potential_energy",
];
/// Checkpoint attribute of a solver's own energy term `name` at t = 0 (e.g.
/// `initial_contact_energy`), written when it is not zero.
fn initial_energy_attr(name: &str) -> String {
    format!("initial_{name}_energy")
}

/// Removes the temporary files a killed run leaves in `dir` (`.snap_000042.h5.tmp-PID`, and the
/// same for checkpoints, `run.xmf` and `summary.json`); returns how many.
fn remove_temporary_files(dir: &Path) -> usize {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return 0;
    };
    rd.filter_map(Result::ok)
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            [".snap_", ".ckpt_", ".run.xmf", ".summary.json"]
                .iter()
                .any(|p| name.starts_with(p))
                && name.contains(".tmp-")
        })
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}

impl<const D: usize> Runner<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// Removes snapshots and checkpoints of an earlier run in the output directory.
    pub(super) fn clean_stale_outputs(&mut self) {
        // The series file and the summary first: if the run dies before it writes its own,
        // nothing points at deleted snapshots or reports the old run as this one.
        let mut removed = 0;
        for name in ["run.xmf", "summary.json"] {
            if std::fs::remove_file(self.out.join(name)).is_ok() {
                removed += 1;
            }
        }
        for prefix in ["snap_", "ckpt_"] {
            for (_, p) in numbered_files(&self.out, prefix) {
                if std::fs::remove_file(&p).is_ok() {
                    removed += 1;
                }
            }
        }
        removed += remove_temporary_files(&self.out);
        if removed > 0 && !self.quiet {
            crate::errln!(
                "note: removed {removed} snapshot, checkpoint, series, summary or temporary files \
                 of an earlier run in {}",
                self.out.display()
            );
        }
    }

    /// Restores the solver from a checkpoint and picks up the output series where it was.
    pub(super) fn resume(&mut self, path: &Path, trust: Verify) -> Result<(), CliError> {
        let bad =
            |m: String| CliError::BadInput(format!("error: --resume {}: {m}", path.display()));
        let ck =
            files::read_file(path, trust).map_err(|e| bad(format!("{e}{}", files::hint(&e))))?;
        if ck.header.kind != FileKind::Checkpoint {
            return Err(bad("not a checkpoint (it is a snapshot)".into()));
        }
        if ck.header.dim as usize != D {
            return Err(bad(format!(
                "checkpoint is {}D, the scene is {D}D",
                ck.header.dim
            )));
        }
        if ck.header.scene != self.scene.text {
            match super::scene_diff::first_difference(&ck.header.scene, &self.scene.text) {
                Ok(None) => {}
                Ok(Some(key)) => {
                    let may = super::MAY_CHANGE.map(|k| format!("`{k}`")).join(", ");
                    return Err(self
                        .scene
                        .error(
                            &key,
                            format!(
                                "differs from the scene stored in checkpoint {}: a resumed run \
                                 continues that scene; only {may} may change",
                                path.display()
                            ),
                        )
                        .into());
                }
                Err(e) => self.warn(format!(
                    "the scene stored in checkpoint {} is not readable ({e}); it is not \
                     compared with this one",
                    path.display()
                )),
            }
        }
        // The solver rebuilds itself around the restored state, re-checking the particles
        // against this scene's grid and materials.
        self.solver
            .restore(&checkpoint_state(&ck))
            .map_err(|e| bad(e.to_string()))?;
        self.first_step = ck.header.step;
        self.first_time = ck.header.time;
        self.last_dt = ck.header.dt;
        self.last_checkpoint_step = Some(ck.header.step);
        let attr = |name: &str| {
            ck.header
                .attrs
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| *v)
        };
        self.frame = attr(ATTR_FRAME).map_or(0, |f| f as u64);
        if let Some(next) = attr(ATTR_NEXT_SNAPSHOT) {
            self.snapshot_schedule.next = next;
        }
        if let (Some(next), Some((s, _))) = (
            attr(ATTR_NEXT_CHECKPOINT),
            self.checkpoint_schedule.as_mut(),
        ) {
            s.next = next;
        }
        let init: Vec<Option<f64>> = ATTR_INITIAL.iter().map(|n| attr(n)).collect();
        if let Some(v) = init.iter().copied().collect::<Option<Vec<f64>>>() {
            self.initial.mass = v[0];
            for a in 0..D {
                self.initial.momentum[a] = v[1 + a];
            }
            for a in 0..3 {
                self.initial.angular_momentum[a] = v[4 + a];
            }
            let parts: Option<Vec<f64>> =
                ATTR_INITIAL_ENERGY_PARTS.iter().map(|n| attr(n)).collect();
            if let Some(p) = parts {
                self.initial.kinetic_energy = p[0];
                self.initial.elastic_energy = p[1];
                self.initial.potential_energy = p[2];
                for (name, value) in &mut self.initial.other_energies {
                    *value = attr(&initial_energy_attr(name)).unwrap_or(0.0);
                }
            }
        }
        for m in &mut self.monitors {
            let now = m.last;
            if let Some(v) = attr(&format!("{ATTR_INITIAL_MONITOR}{}", m.name)) {
                m.initial = v;
            }
            (m.min, m.max) = (m.initial.min(now), m.initial.max(now));
        }
        // Keep the snapshots written before the checkpoint; later ones are rewritten. A kept
        // snapshot of the checkpoint's own step (a run that ended there) is not written again.
        remove_temporary_files(&self.out);
        for (n, p) in numbered_files(&self.out, "snap_") {
            if n >= self.frame {
                let _ = std::fs::remove_file(&p);
                continue;
            }
            // The layout (not the values) as stored, so that f32 fields stay declared as such.
            match files::Checked::open(&p, trust).and_then(|f| f.read_layout()) {
                Ok((h, fields)) => {
                    if h.step == ck.header.step {
                        self.last_snapshot_step = Some(h.step);
                    }
                    self.series.push(vec![SeriesEntry {
                        time: h.time,
                        file: snapshot_name(n),
                        dim: D as u32,
                        fields,
                    }])
                }
                Err(e) => self.warn(format!("earlier snapshot not kept in run.xmf: {e}")),
            }
        }
        if !self.quiet {
            crate::errln!(
                "resuming from {} at t = {:.6} s, step {}",
                path.display(),
                self.solver.time(),
                self.solver.steps()
            );
        }
        Ok(())
    }

    fn header(&self, kind: FileKind, attrs: Vec<(String, f64)>) -> Header {
        Header {
            kind,
            time: self.solver.time(),
            step: self.solver.steps(),
            dt: self.last_dt,
            dim: D as u32,
            units: UNITS.to_string(),
            scene: self.scene.text.clone(),
            code_version: code_version(),
            attrs,
        }
    }

    /// Writes the next snapshot and rewrites `run.xmf`.
    pub(super) fn write_snapshot(&mut self) -> Result<(), CliError> {
        let t = Instant::now();
        let mut columns = snapshot_columns(self.solver.as_ref(), &self.scene.scene.output.fields);
        if crate::distributed::ranks() > 1 {
            // The global ids, to put the ranks' pieces back together.
            columns.extend(self.solver.output(crate::distributed::ID));
        }
        if let Some((name, p, v)) = first_non_finite(&columns) {
            return Err(CliError::Instability(format!(
                "error: non-finite {name} = {v} at particle {p} at step {} (t = {:.6e} s); \
                 snapshot not written",
                self.solver.steps(),
                self.solver.time()
            )));
        }
        let name = crate::distributed::snapshot_piece(self.frame, crate::distributed::rank());
        let header = self.header(
            FileKind::Snapshot,
            vec![("frame".to_string(), self.frame as f64)],
        );
        let storage = self.scene.scene.output.storage();
        write_file_with(&self.out.join(&name), &header, &columns, storage)?;
        let mine = SeriesEntry {
            time: self.solver.time(),
            file: name,
            dim: D as u32,
            fields: columns.iter().map(|f| storage.spec(f)).collect(),
        };
        self.series.push(self.pieces(mine)?);
        if crate::distributed::root() {
            let steps: Vec<&[SeriesEntry]> = self.series.iter().map(Vec::as_slice).collect();
            write_xdmf_pieces(&self.out.join("run.xmf"), &steps)?;
        }
        for (stats, m) in self.monitors.iter_mut().zip(self.solver.monitors()) {
            stats.last = m.value;
            stats.min = stats.min.min(m.value);
            stats.max = stats.max.max(m.value);
        }
        self.frame += 1;
        self.last_snapshot_step = Some(self.solver.steps());
        self.last_good = (self.solver.steps(), self.solver.diagnostics());
        self.io_seconds += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// The pieces of the snapshot this rank has just written as `mine`: on several ranks,
    /// after every rank has written its piece, rank 0 reads the others' layouts from the
    /// output directory (the other ranks keep their own piece only).
    fn pieces(&self, mine: SeriesEntry) -> Result<Vec<SeriesEntry>, CliError> {
        let ranks = crate::distributed::ranks();
        if ranks == 1 {
            return Ok(vec![mine]);
        }
        crate::distributed::barrier();
        if !crate::distributed::root() {
            return Ok(vec![mine]);
        }
        let mut pieces = vec![mine];
        for r in 1..ranks {
            let file = crate::distributed::snapshot_piece(self.frame, r);
            let (_, fields) = read_layout(&self.out.join(&file))?;
            pieces.push(SeriesEntry {
                time: pieces[0].time,
                file,
                dim: D as u32,
                fields,
            });
        }
        Ok(pieces)
    }

    /// Writes a checkpoint of the full state and deletes the oldest beyond `keep`.
    pub(super) fn write_checkpoint(&mut self, keep: u32) -> Result<(), CliError> {
        let t = Instant::now();
        let state = self.solver.checkpoint();
        if let Some((name, p, v)) = first_non_finite(&state.columns) {
            return Err(CliError::Instability(format!(
                "error: non-finite {name} = {v} at particle {p} at step {}; checkpoint not written",
                self.solver.steps()
            )));
        }
        let mut attrs = vec![
            (ATTR_FRAME.to_string(), self.frame as f64),
            (ATTR_NEXT_SNAPSHOT.to_string(), self.snapshot_schedule.next),
        ];
        if let Some((s, _)) = &self.checkpoint_schedule {
            attrs.push((ATTR_NEXT_CHECKPOINT.to_string(), s.next));
        }
        attrs.extend(state.attrs);
        let i = &self.initial;
        let mut init = vec![i.mass];
        init.extend((0..3).map(|a| if a < D { i.momentum[a] } else { 0.0 }));
        init.extend((0..3).map(|a| i.angular_momentum[a]));
        init.push(i.total_energy());
        for (n, v) in ATTR_INITIAL.iter().zip(init) {
            attrs.push((n.to_string(), v));
        }
        for (n, v) in ATTR_INITIAL_ENERGY_PARTS.iter().zip([
            i.kinetic_energy,
            i.elastic_energy,
            i.potential_energy,
        ]) {
            attrs.push((n.to_string(), v));
        }
        for (name, value) in &i.other_energies {
            if *value != 0.0 {
                attrs.push((initial_energy_attr(name), *value));
            }
        }
        for m in &self.monitors {
            attrs.push((format!("{ATTR_INITIAL_MONITOR}{}", m.name), m.initial));
        }
        let name = checkpoint_name(self.solver.steps());
        let header = self.header(FileKind::Checkpoint, attrs);
        write_file(&self.out.join(&name), &header, &state.columns)?;
        self.last_checkpoint_step = Some(self.solver.steps());
        self.checkpoints_written.push(name);
        let all = numbered_files(&self.out, "ckpt_");
        let excess = all.len().saturating_sub(keep as usize);
        for (_, p) in all.into_iter().take(excess) {
            let _ = std::fs::remove_file(p);
        }
        self.io_seconds += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// What an interrupted run leaves: a checkpoint of the current step (unless this run has
    /// just written it), then a snapshot of it. The checkpoint is written first so that it
    /// records the snapshot schedule without this extra frame: `--resume` removes that frame
    /// and continues the series exactly as an uninterrupted run would.
    pub(super) fn write_interrupt_outputs(&mut self) -> Result<(), CliError> {
        let keep = self.checkpoint_schedule.map_or(1, |(_, c)| c.keep);
        let name = checkpoint_name(self.solver.steps());
        // Runs on several ranks write no checkpoints yet (refused at start when asked for).
        if crate::distributed::ranks() == 1 && self.checkpoints_written.last() != Some(&name) {
            self.write_checkpoint(keep)?;
        }
        if self.last_snapshot_step != Some(self.solver.steps()) {
            self.write_snapshot()?;
        }
        Ok(())
    }
}
