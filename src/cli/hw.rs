//! `luxnode hw`: the board's peripherals by hand: probe the ambient light sensor and the
//! calibration EEPROM, write a camera module's calibration record.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use luxnode::board::Board;
use luxnode::board::peripherals::{SimHooks, open, record_from_board};
use luxnode::peripherals::calibration;

/// `luxnode hw`.
#[derive(clap::Subcommand)]
pub enum Command {
    /// Read the ambient light sensor once (auto-ranged) and the calibration EEPROM's records.
    Probe {
        /// The board file.
        #[arg(long, value_name = "FILE")]
        board: PathBuf,
    },
    /// Write the board file's colour calibration ([camera.colour.registration] and
    /// calibration_cd_m2_s) into the camera module's EEPROM, as a new record generation.
    WriteCalibration {
        /// The board file.
        #[arg(long, value_name = "FILE")]
        board: PathBuf,
        /// The module's serial number (up to 16 ASCII characters).
        #[arg(long, value_name = "SERIAL")]
        serial: String,
    },
}

/// Runs `luxnode hw ...`.
pub fn run(command: &Command) -> Result<()> {
    match command {
        Command::Probe { board } => {
            let b = Board::load(board)?;
            let mut p = open(b.i2c.as_ref(), None, None, SimHooks::default());
            for f in &p.open_faults {
                println!("fault: {f}");
            }
            match &p.als {
                Some(a) => {
                    let mut a = a.lock().unwrap_or_else(|e| e.into_inner());
                    match a.measure() {
                        Ok(r) => println!(
                            "ambient light: {:.3} lx (ALS {} counts, white {}, gain x{}, {} ms)",
                            r.lux_lx,
                            r.als,
                            r.white,
                            r.setting.gain.factor(),
                            r.setting.it.ms()
                        ),
                        Err(e) => println!("ambient light: {e}"),
                    }
                }
                None if b.i2c.as_ref().is_some_and(|i| i.als.is_some()) => {
                    println!("ambient light: not opened (the bus fault above)")
                }
                None => println!("ambient light: no [i2c.als]"),
            }
            match p.eeprom.as_mut() {
                Some(e) => match calibration::read(&mut e.eeprom) {
                    Ok(s) => {
                        for (name, copy) in [("A", &s.a), ("B", &s.b)] {
                            match copy {
                                Ok((c, g)) => println!(
                                    "calibration copy {name}: generation {g}, module {}, {}x{}, fx {:.1}, {}, {:.3} cd/m2 s",
                                    c.serial_str(),
                                    c.width,
                                    c.height,
                                    c.fx,
                                    match c.fisheye_k {
                                        Some(k) => format!("Kannala-Brandt fisheye k {k:?}"),
                                        None => format!("pinhole k1 {} k2 {}", c.k1, c.k2),
                                    },
                                    c.calibration_cd_m2_s
                                ),
                                Err(e) => println!("calibration copy {name}: {e}"),
                            }
                        }
                    }
                    Err(err) => println!("calibration EEPROM {}: {err}", e.name),
                },
                None if b.i2c.as_ref().is_some_and(|i| i.eeprom.is_some()) => {
                    println!("calibration EEPROM: not opened (the bus fault above)")
                }
                None => println!("calibration EEPROM: no [i2c.eeprom]"),
            }
            Ok(())
        }
        Command::WriteCalibration { board, serial } => {
            let b = Board::load(board)?;
            let cal = record_from_board(&b.camera, serial)
                .map_err(|e| anyhow::anyhow!("board {}: {e}", b.name))?;
            let mut p = open(b.i2c.as_ref(), None, None, SimHooks::default());
            let Some(e) = p.eeprom.as_mut() else {
                bail!("board {}: no [i2c.eeprom]", b.name);
            };
            let (g, copy) = calibration::write(&mut e.eeprom, &mut *e.delay, &cal)
                .map_err(|err| anyhow::anyhow!("{}: {err:?}", e.name))
                .context("writing the calibration record")?;
            println!(
                "calibration of module {serial} written to {} as generation {g} (copy {}), read back",
                e.name,
                if copy == 0 { "A" } else { "B" }
            );
            Ok(())
        }
    }
}
