//! `fit-brdf completions SHELL [--install]`: the shell completion script, generated from
//! the clap definition of the command line (so it always lists every subcommand and
//! option), on standard output or installed where the shell looks for it.

use crate::cli::{Cli, CompletionsArgs};
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::{write_atomic, write_text};
use anyhow::Context;
use clap::CommandFactory;
use clap_complete::Shell;
use std::path::PathBuf;

/// Where `--install` puts the script of `shell`, and what the user still has to do
/// (None: the shell loads it in new sessions by itself). `var` reads the environment.
fn install_path(
    shell: Shell,
    var: impl Fn(&str) -> Option<PathBuf>,
) -> CliResult<(PathBuf, Option<&'static str>)> {
    let home = || {
        var("HOME").ok_or_else(|| bad_msg("--install: HOME is not set; print the script instead"))
    };
    // XDG base directories: an unset or relative value means the default (the spec).
    let xdg = |name: &str, default: &str| -> CliResult<PathBuf> {
        match var(name).filter(|p| p.is_absolute()) {
            Some(p) => Ok(p),
            None => Ok(home()?.join(default)),
        }
    };
    Ok(match shell {
        // bash-completion loads completions/<command> from here on first use.
        Shell::Bash => (
            xdg("XDG_DATA_HOME", ".local/share")?.join("bash-completion/completions/fit-brdf"),
            None,
        ),
        // fish loads completions/<command>.fish by itself.
        Shell::Fish => (
            xdg("XDG_CONFIG_HOME", ".config")?.join("fish/completions/fit-brdf.fish"),
            None,
        ),
        // zsh has no per-user folder of its own: ~/.zfunc is the common one.
        Shell::Zsh => (
            home()?.join(".zfunc/_fit-brdf"),
            Some(
                "zsh reads it once ~/.zshrc has `fpath=(~/.zfunc $fpath)` before \
                 `autoload -U compinit && compinit`",
            ),
        ),
        other => {
            return Err(bad_msg(format!(
                "--install knows where bash, zsh and fish look; for {other} print the \
                 script (`fit-brdf completions {other}`) and load it from your shell's profile"
            )));
        }
    })
}

pub fn run(a: CompletionsArgs) -> CliResult<()> {
    let mut cmd = Cli::command();
    let mut buf = Vec::new();
    clap_complete::generate(a.shell, &mut cmd, "fit-brdf", &mut buf);
    if !a.install {
        let text = String::from_utf8(buf)
            .context("the completion script is not UTF-8")
            .map_err(runtime)?;
        return write_text(None, &text);
    }
    let (path, todo) = install_path(a.shell, |k| std::env::var_os(k).map(PathBuf::from))?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the folder", dir.display()))
            .map_err(runtime)?;
    }
    write_atomic(&path, &buf)?;
    let then = todo.unwrap_or("new shells complete fit-brdf");
    write_text(None, &format!("installed {}; {then}\n", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(pairs: &'a [(&str, &str)]) -> impl Fn(&str) -> Option<PathBuf> + 'a {
        move |k| {
            pairs
                .iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| PathBuf::from(v))
        }
    }

    #[test]
    fn install_paths_follow_xdg_and_fall_back_to_home() {
        let p = |s, e: &[(&str, &str)]| install_path(s, env(e)).map(|(p, _)| p).ok();
        let home = [("HOME", "/h")];
        assert_eq!(
            p(Shell::Bash, &home),
            Some("/h/.local/share/bash-completion/completions/fit-brdf".into())
        );
        assert_eq!(
            p(Shell::Bash, &[("HOME", "/h"), ("XDG_DATA_HOME", "/d")]),
            Some("/d/bash-completion/completions/fit-brdf".into())
        );
        // A relative XDG value is ignored (the XDG base directory spec).
        assert_eq!(
            p(Shell::Bash, &[("HOME", "/h"), ("XDG_DATA_HOME", "rel")]),
            p(Shell::Bash, &home)
        );
        assert_eq!(
            p(Shell::Fish, &[("HOME", "/h"), ("XDG_CONFIG_HOME", "/c")]),
            Some("/c/fish/completions/fit-brdf.fish".into())
        );
        assert_eq!(p(Shell::Zsh, &home), Some("/h/.zfunc/_fit-brdf".into()));
        assert!(install_path(Shell::Zsh, env(&home)).unwrap().1.is_some());
        // Unknown places and no HOME are bad input (exit 2).
        for (s, e) in [(Shell::Elvish, &home[..]), (Shell::Bash, &[][..])] {
            assert_eq!(install_path(s, env(e)).unwrap_err().exit_code(), 2);
        }
    }
}
