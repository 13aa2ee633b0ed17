//! What `mpm-cli run` prints on the terminal: the progress line while it runs and the timing
//! report at the end.

use super::Runner;
use mpm_core::{Dim, DimOps};
use std::io::Write;
use std::time::Instant;

impl<const D: usize> Runner<'_, D>
where
    Dim<D>: DimOps<D>,
{
    pub(super) fn print_report(&self, wall_s: f64) {
        let table = self.solver.stage_times();
        let stage_total: f64 = table.iter().map(|r| r.seconds).sum();
        let particles: usize = crate::distributed::gather_counts(self.solver.particles().len())
            .iter()
            .sum();
        let mut out = String::new();
        out.push_str(&format!(
            "done: {} steps ({} this run) to t = {:.6} s, {} particles, {} snapshots, wall {:.2} s\n",
            self.solver.steps(),
            self.steps_this_run,
            self.solver.time(),
            particles,
            self.frame,
            wall_s
        ));
        let share = |s: f64| 100.0 * s / wall_s.max(1e-12);
        out.push_str("stage                    seconds   share\n");
        for row in &table {
            out.push_str(&format!(
                "{:<23} {:>9.3}  {:>5.1}%\n",
                row.stage.name(),
                row.seconds,
                share(row.seconds)
            ));
            for (part, s) in &row.parts {
                out.push_str(&format!("  {part:<21} {s:>9.3}  {:>5.1}%\n", share(*s)));
            }
        }
        out.push_str(&format!(
            "{:<23} {:>9.3}  {:>5.1}%\n",
            "output (I/O)",
            self.io_seconds,
            share(self.io_seconds)
        ));
        out.push_str(&format!("{:<23} {:>9.3}\n", "solver total", stage_total));
        out.push_str(&format!("{:<23} {:>9.3}\n", "wall total", wall_s));
        if self.steps_this_run > 0 {
            out.push_str(&format!(
                "dt min/mean/max: {:.3e} / {:.3e} / {:.3e} s\n",
                self.dt_min,
                self.dt_sum / self.steps_this_run as f64,
                self.dt_max
            ));
            for (name, s) in &self.solves {
                out.push_str(&format!(
                    "{name} iterations per step mean/max: {:.2} / {}; final residual max {:.3e}\n",
                    s.total as f64 / s.steps as f64,
                    s.max,
                    s.residual_max
                ));
            }
        }
        for m in &self.monitors {
            out.push_str(&format!(
                "{}: initial {:.6e} {}, final {:.6e} (drift {:+.3e}), range [{:.6e}, {:.6e}] over snapshots\n",
                m.name,
                m.initial,
                m.unit,
                m.last,
                m.last / m.initial - 1.0,
                m.min,
                m.max
            ));
        }
        out.push_str(&format!(
            "summary: {}\n",
            self.out.join("summary.json").display()
        ));
        crate::out!("{out}");
        let _ = std::io::stdout().flush();
    }
}

/// Progress on stderr: a refreshed line on a terminal, occasional plain lines otherwise,
/// nothing with `--quiet`.
pub(super) struct Progress {
    quiet: bool,
    tty: bool,
    last: Instant,
    next_fraction: f64,
    drawn: bool,
}

impl Progress {
    pub(super) fn new(quiet: bool, tty: bool) -> Self {
        Self {
            quiet,
            tty,
            last: Instant::now(),
            next_fraction: 0.1,
            drawn: false,
        }
    }

    pub(super) fn update(&mut self, fraction: f64, time: f64, step: u64, dt: f64, start: Instant) {
        if self.quiet {
            return;
        }
        let elapsed = start.elapsed().as_secs_f64();
        let eta = if fraction > 0.0 {
            elapsed * (1.0 - fraction) / fraction
        } else {
            f64::NAN
        };
        if self.tty {
            if self.last.elapsed().as_secs_f64() < 0.1 {
                return;
            }
            self.last = Instant::now();
            let width = 24;
            let filled = ((fraction * width as f64).round() as usize).min(width);
            crate::err!(
                "\r\x1b[2K[{}{}] {:5.1}%  t = {:.4e} s  step {}  dt = {:.3e} s  ETA {}",
                "#".repeat(filled),
                "-".repeat(width - filled),
                100.0 * fraction,
                time,
                step,
                dt,
                fmt_duration(eta)
            );
            self.drawn = true;
        } else if fraction >= self.next_fraction {
            while self.next_fraction <= fraction {
                self.next_fraction += 0.1;
            }
            crate::errln!(
                "{:5.1}%  t = {:.4e} s  step {}  dt = {:.3e} s  elapsed {}  ETA {}",
                100.0 * fraction,
                time,
                step,
                dt,
                fmt_duration(elapsed),
                fmt_duration(eta)
            );
        }
    }

    pub(super) fn finish(&mut self) {
        if self.drawn {
            crate::errln!();
        }
    }
}

/// `m:ss` or `h:mm:ss`.
fn fmt_duration(s: f64) -> String {
    if !s.is_finite() {
        return "?".into();
    }
    let s = s.round() as u64;
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}
