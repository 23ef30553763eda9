//! Where the log goes: `tracing` events on stderr. On a terminal they are coloured and
//! timestamped; under systemd (`JOURNAL_STREAM` set) each line starts with its syslog priority
//! (`<3>` error .. `<7>` debug), which journald reads as the entry's priority, with no colour
//! and no timestamp (journald has its own); into a pipe or file, plain text. `RUST_LOG` sets
//! the level (default `info`).

use std::fmt;
use std::io::IsTerminal;

use tracing::{Event, Level, Subscriber};
use tracing_subscriber::EnvFilter;
use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::{FmtContext, FormatEvent, FormatFields};
use tracing_subscriber::registry::LookupSpan;

/// One line per event, `<priority>target: message fields` (sd-daemon(3) log levels).
pub struct JournalFormat;

/// The syslog priority of a level.
pub fn priority(level: &Level) -> u8 {
    match *level {
        Level::ERROR => 3,
        Level::WARN => 4,
        Level::INFO => 6,
        Level::DEBUG | Level::TRACE => 7,
    }
}

impl<S, N> FormatEvent<S, N> for JournalFormat
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    N: for<'a> FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        ctx: &FmtContext<'_, S, N>,
        mut writer: Writer<'_>,
        event: &Event<'_>,
    ) -> fmt::Result {
        let meta = event.metadata();
        write!(writer, "<{}>{}: ", priority(meta.level()), meta.target())?;
        ctx.field_format().format_fields(writer.by_ref(), event)?;
        writeln!(writer)
    }
}

/// Installs the subscriber for this process.
pub fn init() {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    if std::env::var_os("JOURNAL_STREAM").is_some() {
        builder.with_ansi(false).event_format(JournalFormat).init();
    } else if std::io::stderr().is_terminal() {
        builder.with_writer(LineOfItsOwn::stderr).init();
    } else {
        builder.with_ansi(false).init();
    }
}

/// stderr on a terminal, each log line starting on a cleared line: a progress spinner drawn
/// there (commissioning stages, benchmarks) is wiped first, not left in front of the line, and
/// redrawn below it at its next tick.
pub struct LineOfItsOwn {
    err: std::io::Stderr,
    cleared: bool,
}

impl LineOfItsOwn {
    fn stderr() -> Self {
        LineOfItsOwn {
            err: std::io::stderr(),
            cleared: false,
        }
    }
}

impl std::io::Write for LineOfItsOwn {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if !self.cleared {
            self.err.write_all(b"\r\x1b[2K")?;
            self.cleared = true;
        }
        self.err.write(b)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.err.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn journal_lines_carry_the_syslog_priority() {
        use std::sync::{Arc, Mutex};
        #[derive(Clone, Default)]
        struct Buf(Arc<Mutex<Vec<u8>>>);
        impl std::io::Write for Buf {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                self.0
                    .lock()
                    .map_err(|_| std::io::ErrorKind::Other)?
                    .extend_from_slice(b);
                Ok(b.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let buf = Buf::default();
        let out = buf.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_writer(move || out.clone())
            .with_ansi(false)
            .event_format(JournalFormat)
            .finish();
        tracing::subscriber::with_default(subscriber, || {
            tracing::error!(slot = "B", "flash: write failed");
            tracing::warn!("gateway link lost");
            tracing::info!("modbus tcp listening on 127.0.0.1:1502");
        });
        let text = String::from_utf8(buf.0.lock().unwrap().clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert!(
            lines[0].starts_with("<3>") && lines[0].contains("flash: write failed slot=\"B\""),
            "{text}"
        );
        assert!(lines[1].starts_with("<4>"), "{text}");
        assert!(
            lines[2].starts_with("<6>") && lines[2].ends_with("listening on 127.0.0.1:1502"),
            "{text}"
        );
        assert!(!text.contains('\u{1b}'), "no ANSI escapes: {text:?}");
    }
}
