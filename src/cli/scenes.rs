//! `phyxel scenes`: the built-in scenes, listed or printed as TOML.

use phyxel::scene::{BUILTIN, Scene};
use std::process::ExitCode;

pub(crate) fn scenes(show: Option<String>) -> ExitCode {
    match show {
        None => {
            for (name, text) in BUILTIN {
                let scene = Scene::parse(text, name).expect("built-in scenes are valid");
                println!("{name:<16} {}", scene.description);
            }
            ExitCode::SUCCESS
        }
        Some(name) => match BUILTIN.iter().find(|(n, _)| *n == name) {
            Some((_, text)) => {
                print!("{text}");
                ExitCode::SUCCESS
            }
            None => {
                let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
                eprintln!(
                    "error: unknown scene '{name}' (built-in scenes: {})",
                    names.join(", ")
                );
                ExitCode::FAILURE
            }
        },
    }
}
