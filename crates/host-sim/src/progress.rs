//! Progress bars of the long commands (`simulate`, `replay`): one style for
//! every phase (`simulating`, `rendering`, `replay`), drawn on stderr when it
//! is a terminal and not at all otherwise.
//!
//! A [`Progress`] makes the bars of a run. Hidden, its bars still count
//! (`ProgressBar::position`) but draw nothing; [`Progress::bars`] gives the
//! bars it made, so a test can check what a run counted.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::Mutex;

/// The template of every bar: the phase, the bar, how far, what is counted.
pub const TEMPLATE: &str = "{prefix:>10} {bar:40} {percent:>3}% {pos}/{len} {msg}, eta {eta}";

/// Where a [`Progress`] draws its bars.
type Target = Box<dyn Fn() -> ProgressDrawTarget + Send + Sync>;

/// Makes the progress bars of one run, all drawn to the same place.
pub struct Progress {
    target: Target,
    made: Mutex<Vec<ProgressBar>>,
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Progress")
            .field("bars", &self.bars().len())
            .finish()
    }
}

impl Progress {
    /// Bars on stderr when `shown` (the commands pass whether stderr is a
    /// terminal), hidden otherwise.
    pub fn new(shown: bool) -> Self {
        if shown {
            Self::to(ProgressDrawTarget::stderr)
        } else {
            Self::hidden()
        }
    }

    /// Bars that count but draw nothing.
    pub fn hidden() -> Self {
        Self::to(ProgressDrawTarget::hidden)
    }

    /// Bars drawn wherever `target` says (each bar gets its own target).
    pub fn to(target: impl Fn() -> ProgressDrawTarget + Send + Sync + 'static) -> Self {
        Self {
            target: Box::new(target),
            made: Mutex::new(Vec::new()),
        }
    }

    /// A bar for `phase` that counts `len` of `unit`, at 0.
    pub fn bar(&self, phase: &'static str, len: u64, unit: &'static str) -> ProgressBar {
        let style =
            ProgressStyle::with_template(TEMPLATE).unwrap_or_else(|_| ProgressStyle::default_bar());
        let b = ProgressBar::with_draw_target(Some(len), (self.target)())
            .with_style(style)
            .with_prefix(phase)
            .with_message(unit);
        if let Ok(mut made) = self.made.lock() {
            made.push(b.clone());
        }
        b
    }

    /// The bars made so far, in order.
    pub fn bars(&self) -> Vec<ProgressBar> {
        self.made.lock().map(|m| m.clone()).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use indicatif::TermLike;
    use std::io;
    use std::sync::Arc;

    /// A terminal that keeps what is written to it.
    #[derive(Debug, Default, Clone)]
    struct Memory(Arc<Mutex<String>>);

    impl Memory {
        fn text(&self) -> String {
            self.0.lock().unwrap().clone()
        }
        fn push(&self, s: &str) -> io::Result<()> {
            self.0.lock().unwrap().push_str(s);
            Ok(())
        }
    }

    impl TermLike for Memory {
        fn width(&self) -> u16 {
            100
        }
        fn move_cursor_up(&self, _: usize) -> io::Result<()> {
            self.push("\x1b[A")
        }
        fn move_cursor_down(&self, _: usize) -> io::Result<()> {
            self.push("\x1b[B")
        }
        fn move_cursor_right(&self, _: usize) -> io::Result<()> {
            self.push("\x1b[C")
        }
        fn move_cursor_left(&self, _: usize) -> io::Result<()> {
            self.push("\x1b[D")
        }
        fn write_line(&self, s: &str) -> io::Result<()> {
            self.push(s)?;
            self.push("\n")
        }
        fn write_str(&self, s: &str) -> io::Result<()> {
            self.push(s)
        }
        fn clear_line(&self) -> io::Result<()> {
            self.push("\r\x1b[2K")
        }
        fn flush(&self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn shown_bars_draw_phase_count_and_unit() {
        let term = Memory::default();
        let t = term.clone();
        let p = Progress::to(move || ProgressDrawTarget::term_like(Box::new(t.clone())));
        let b = p.bar("rendering", 8, "images");
        b.inc(3);
        let text = term.text();
        assert!(text.contains("rendering"), "{text:?}");
        assert!(text.contains("3/8 images"), "{text:?}");
        assert!(!b.is_hidden());
    }

    #[test]
    fn hidden_bars_count_and_draw_nothing() {
        for p in [Progress::hidden(), Progress::new(false)] {
            let b = p.bar("replay", 10, "samples");
            assert!(b.is_hidden());
            b.inc(4);
            b.set_position(7);
            assert_eq!(b.position(), 7);
            let bars = p.bars();
            assert_eq!(bars.len(), 1);
            assert_eq!(bars[0].prefix(), "replay");
            assert_eq!(bars[0].message(), "samples");
            assert_eq!((bars[0].position(), bars[0].length()), (7, Some(10)));
        }
    }
}
