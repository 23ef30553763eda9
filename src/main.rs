//! `luxnode`: the command line of the node. It parses the arguments, sets up logging and hands
//! each command to its file under `src/cli/`; all logic lives in the library.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

#[derive(Parser)]
#[command(
    name = "luxnode",
    version,
    about = "Desk illuminance from a ceiling ToF + RGB camera"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Summarise a photometric file (EULUMDAT .ldt or IES .ies).
    Photometry(cli::photometry::Args),
    /// Scene directories (the format of docs/formats.md).
    Scene {
        #[command(subcommand)]
        command: cli::scene::Command,
    },
    /// Compute desk illuminance for lighting scenarios.
    Simulate(Box<cli::simulate::Args>),
    /// The flash image: build one from a scene, inspect one, evaluate dimming states.
    Image {
        #[command(subcommand)]
        command: Box<cli::image::Command>,
    },
    /// Serve a commissioned image over Modbus TCP (and RTU, BACnet/IP), optionally following a
    /// DALI gateway.
    Serve(Box<cli::modbus::ServeArgs>),
    /// The Modbus register map.
    Modbus {
        #[command(subcommand)]
        command: cli::modbus::ModbusCommand,
    },
    /// BACnet/IP: the PICS (docs/bacnet.md).
    Bacnet {
        #[command(subcommand)]
        command: cli::modbus::BacnetCommand,
    },
    /// Commission from a capture set (ToF depth + luminance frames, no CAD model) and write
    /// the flash image.
    Commission(Box<cli::commission::Args>),
    /// Benchmarks that print tables (and plots) for docs/.
    #[cfg(feature = "bench")]
    Bench {
        #[command(subcommand)]
        command: cli::bench::Command,
    },
    /// The least-power dimming state that meets every desk's target (from an image).
    Control(Box<cli::control::Args>),
    /// Live light from one frame: measured and inferred desk lux with the daylight split out.
    Live(Box<cli::live::Args>),
    /// Run the node on a board.
    Run(Box<cli::run::Args>),
    /// The integrator's points list: every published value with its point, unit, Modbus
    /// address and type, and BACnet object (CSV, JSON, or BACnet EDE).
    Points(Box<cli::points::Args>),
    /// The commissioning report of an image: report.html (self-contained) and results.json.
    #[cfg(feature = "report")]
    Report(Box<cli::report::Args>),
    /// The board's peripherals: probe the ambient light sensor and the calibration EEPROM,
    /// write a camera module's calibration record.
    Hw {
        #[command(subcommand)]
        command: cli::hw::Command,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if !matches!(cli.command, Command::Run(_) | Command::Serve(_)) && !is_bench(&cli.command) {
        end_quietly_on_a_closed_pipe();
    }
    cli::logging::init();
    let done = match cli.command {
        Command::Photometry(a) => cli::photometry::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Scene { command } => cli::scene::run(&command),
        Command::Simulate(a) => cli::simulate::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Image { command } => cli::image::run(&command).map(|()| ExitCode::SUCCESS),
        Command::Serve(a) => cli::modbus::serve(&a).map(|()| ExitCode::SUCCESS),
        Command::Modbus { command } => cli::modbus::modbus(&command).map(|()| ExitCode::SUCCESS),
        Command::Bacnet { command } => cli::modbus::bacnet(&command).map(|()| ExitCode::SUCCESS),
        Command::Commission(a) => cli::commission::run(&a).map(|()| ExitCode::SUCCESS),
        #[cfg(feature = "bench")]
        Command::Bench { command } => cli::bench::run(command).map(|()| ExitCode::SUCCESS),
        Command::Control(a) => cli::control::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Live(a) => cli::live::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Run(a) => cli::run::run(&a),
        Command::Points(a) => cli::points::run(&a).map(|()| ExitCode::SUCCESS),
        #[cfg(feature = "report")]
        Command::Report(a) => cli::report::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Hw { command } => cli::hw::run(&command).map(|()| ExitCode::SUCCESS),
    };
    match done {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            ExitCode::FAILURE
        }
    }
}

/// An error and its causes on one line, each cause once: a cause whose text an outer message
/// already carries (a typed error that names its source) is not repeated (issue 31: "No such
/// file or directory (os error 2): No such file or directory (os error 2)").
fn error_chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// True for the benchmarks (some of them are Modbus clients and servers).
fn is_bench(command: &Command) -> bool {
    #[cfg(feature = "bench")]
    if matches!(command, Command::Bench { .. }) {
        return true;
    }
    let _ = command;
    false
}

/// A one-shot command ends quietly when its reader goes away (`luxnode image info IMG | head
/// -1`), as any Unix filter does: SIGPIPE back to its default action. The Rust runtime ignores
/// SIGPIPE, and `println!` then panics on the broken pipe (exit 101). The servers (`run`,
/// `serve`, the benchmarks) keep it ignored: a client that hangs up is an error on its socket,
/// never the end of the node.
#[cfg(unix)]
#[allow(unsafe_code)]
fn end_quietly_on_a_closed_pipe() {
    use nix::sys::signal::{SigHandler, Signal, signal};
    // SAFETY: called first in main, before any thread exists; SIG_DFL installs no handler
    // code, so no async-signal-safety question arises.
    let _ = unsafe { signal(Signal::SIGPIPE, SigHandler::SigDfl) };
}

#[cfg(not(unix))]
fn end_quietly_on_a_closed_pipe() {}
