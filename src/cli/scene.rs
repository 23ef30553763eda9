//! `luxnode scene check DIR`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Result, bail};
use luxnode::scene::Scene;

use super::SceneArgs;

/// `luxnode scene ...`.
#[derive(clap::Subcommand)]
pub enum Command {
    /// Validate a scene directory and print what it contains; non-zero exit on errors.
    Check {
        /// The scene directory.
        dir: PathBuf,
        #[command(flatten)]
        load: SceneArgs,
    },
}

/// Runs `luxnode scene ...`.
pub fn run(command: &Command) -> Result<ExitCode> {
    let Command::Check { dir, load } = command;
    if !dir.is_dir() {
        bail!("{} is not a directory", dir.display());
    }
    match Scene::load(dir, &load.options()) {
        Ok(scene) => {
            print!("{}", scene.summary());
            let limits =
                luxnode::image_build::served_limits(scene.sensors.len(), scene.luminaires.len());
            if !limits.is_empty() {
                for l in &limits {
                    eprintln!("error: {l}");
                }
                eprintln!(
                    "scene {}: valid as a scene, but the node cannot serve it",
                    scene.name
                );
                return Ok(ExitCode::FAILURE);
            }
            println!("OK: scene {} is valid", scene.name);
            Ok(ExitCode::SUCCESS)
        }
        Err(errors) => {
            eprintln!("{errors}");
            Ok(ExitCode::FAILURE)
        }
    }
}
