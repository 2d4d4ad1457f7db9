//! Progress reporting, passed to stages as an observer: indicatif bars on a terminal, plain lines
//! on stderr otherwise (CI logs, cron mails), nothing in tests.
//!
//! Stages only call [`Progress::stage`] and the returned [`StageProgress`]; they never know how
//! progress is shown. stdout is never touched (it carries data for `query` and `diff`).

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// An observer of stage progress.
pub trait Progress: Send + Sync {
    /// Start a stage that will process `total` units (files, segments, fits).
    fn stage(&self, name: &str, unit: &str, total: u64) -> Box<dyn StageProgress>;
    /// A one-line log message (stderr).
    fn note(&self, message: &str);
}

/// Progress of one stage.
pub trait StageProgress: Send + Sync {
    /// `n` more units done.
    fn inc(&self, n: u64);
    /// Stage finished; `summary` is a short result line.
    fn finish(&self, summary: &str);
}

/// Pick the reporter for this process: bars on a terminal, plain lines otherwise.
pub fn for_stderr() -> Box<dyn Progress> {
    if std::io::stderr().is_terminal() {
        Box::new(Bars::new())
    } else {
        Box::new(Lines)
    }
}

/// No output at all (tests, library use).
#[derive(Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn stage(&self, _: &str, _: &str, _: u64) -> Box<dyn StageProgress> {
        Box::new(Silent)
    }
    fn note(&self, _: &str) {}
}

impl StageProgress for Silent {
    fn inc(&self, _: u64) {}
    fn finish(&self, _: &str) {}
}

/// indicatif bars, one per stage.
pub struct Bars {
    multi: MultiProgress,
}

impl Bars {
    fn new() -> Self {
        Bars {
            multi: MultiProgress::with_draw_target(ProgressDrawTarget::stderr()),
        }
    }
}

impl Progress for Bars {
    fn stage(&self, name: &str, unit: &str, total: u64) -> Box<dyn StageProgress> {
        let bar = self.multi.add(ProgressBar::new(total));
        let template = format!(
            "{{prefix:>10.bold}} [{{bar:32.cyan/blue}}] {{pos}}/{{len}} {unit} {{elapsed_precise}} {{msg}}"
        );
        bar.set_style(
            ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(name.to_string());
        bar.enable_steady_tick(Duration::from_millis(200));
        Box::new(bar)
    }

    fn note(&self, message: &str) {
        let _ = self.multi.println(message);
    }
}

impl StageProgress for ProgressBar {
    fn inc(&self, n: u64) {
        ProgressBar::inc(self, n);
    }
    fn finish(&self, summary: &str) {
        self.finish_with_message(summary.to_string());
    }
}

/// Plain lines on stderr: a start line, at most one line per 10 % or per 10 s, a finish line.
#[derive(Debug, Default)]
pub struct Lines;

impl Progress for Lines {
    fn stage(&self, name: &str, unit: &str, total: u64) -> Box<dyn StageProgress> {
        eprintln!("{name}: {total} {unit}");
        Box::new(LineStage {
            name: name.to_string(),
            unit: unit.to_string(),
            total,
            done: AtomicU64::new(0),
            last: Mutex::new((Instant::now(), 0)),
            start: Instant::now(),
        })
    }

    fn note(&self, message: &str) {
        eprintln!("{message}");
    }
}

struct LineStage {
    name: String,
    unit: String,
    total: u64,
    done: AtomicU64,
    last: Mutex<(Instant, u64)>,
    start: Instant,
}

impl StageProgress for LineStage {
    fn inc(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        let step = (self.total / 10).max(1);
        if done >= last.1 + step || last.0.elapsed() >= Duration::from_secs(10) {
            *last = (Instant::now(), done);
            eprintln!("{}: {done}/{} {}", self.name, self.total, self.unit);
        }
    }

    fn finish(&self, summary: &str) {
        eprintln!(
            "{}: done in {:.1} s: {summary}",
            self.name,
            self.start.elapsed().as_secs_f64()
        );
    }
}
