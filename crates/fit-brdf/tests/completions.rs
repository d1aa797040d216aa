//! `fit-brdf completions SHELL`: a completion script for every shell clap_complete knows,
//! listing every subcommand; and the help conventions of batch, export and completions.

#[macro_use]
mod common;

use common::{bin, stderr};

/// The subcommands as `fit-brdf --help` lists them (so a new one is checked too).
fn subcommands() -> Vec<String> {
    let o = fit_brdf!("--help");
    assert!(o.status.success());
    let help = String::from_utf8(o.stdout).unwrap();
    let section = help
        .split("Commands:")
        .nth(1)
        .expect("a Commands: section")
        .split("\n\n")
        .next()
        .unwrap();
    let v: Vec<String> = section
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|n| n != "help")
        .collect();
    assert!(v.len() >= 10, "{v:?}");
    v
}

#[test]
fn bash_completion_mentions_every_subcommand() {
    let o = fit_brdf!("completions", "bash");
    assert!(o.status.success());
    let script = String::from_utf8(o.stdout).unwrap();
    assert!(
        script.contains("complete -F _fit__brdf"),
        "a bash completion script"
    );
    for sub in subcommands() {
        // The dispatch line `fit__brdf,<sub>)` that completes the subcommand's options.
        assert!(
            script.contains(&format!("fit__brdf,{sub})")),
            "bash completion lacks `{sub}`"
        );
    }
    // Options of a subcommand are completed too.
    assert!(script.contains("--shard") && script.contains("--format"));
}

#[test]
fn every_shell_gets_a_script_and_a_bad_shell_is_a_usage_error() {
    for (shell, marker) in [
        ("zsh", "#compdef fit-brdf"),
        ("fish", "complete -c fit-brdf"),
        ("elvish", "fit-brdf"),
        ("powershell", "Register-ArgumentCompleter"),
    ] {
        let o = fit_brdf!("completions", shell);
        assert!(o.status.success(), "{shell}");
        let s = String::from_utf8(o.stdout).unwrap();
        assert!(s.contains(marker), "{shell}: {}", &s[..s.len().min(200)]);
        assert!(s.contains("batch") && s.contains("export"), "{shell}");
    }
    let o = fit_brdf!("completions", "tcsh");
    assert_eq!(o.status.code(), Some(2));
    let o = fit_brdf!("completions");
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn batch_export_and_completions_show_examples_in_their_help() {
    for sub in ["batch", "export", "completions"] {
        let o = fit_brdf!(sub, "--help");
        assert!(o.status.success(), "{sub}");
        let h = String::from_utf8(o.stdout).unwrap();
        assert!(
            h.contains("Examples:") && h.contains(&format!("fit-brdf {sub} ")),
            "{sub}: {h}"
        );
    }
}

#[test]
fn install_creates_the_folder_and_writes_where_each_shell_looks() {
    let d = tempfile::tempdir().unwrap();
    let home = d.path().join("home");
    std::fs::create_dir(&home).unwrap();
    let run = |args: &[&str], xdg: Option<&std::path::Path>| {
        let mut c = bin();
        c.args(args)
            .env("HOME", &home)
            .env_remove("XDG_DATA_HOME")
            .env_remove("XDG_CONFIG_HOME");
        if let Some(x) = xdg {
            c.env("XDG_DATA_HOME", x).env("XDG_CONFIG_HOME", x);
        }
        c.output().unwrap()
    };
    let script = |shell: &str| run(&["completions", shell], None).stdout;
    for (shell, xdg, want) in [
        // The case: ~/.local/share/bash-completion/completions does not exist.
        (
            "bash",
            None,
            home.join(".local/share/bash-completion/completions/fit-brdf"),
        ),
        (
            "bash",
            Some(d.path().join("data")),
            d.path().join("data/bash-completion/completions/fit-brdf"),
        ),
        (
            "fish",
            None,
            home.join(".config/fish/completions/fit-brdf.fish"),
        ),
        ("zsh", None, home.join(".zfunc/_fit-brdf")),
    ] {
        assert!(!want.exists());
        // Twice: the second replaces the first.
        for _ in 0..2 {
            let o = run(&["completions", shell, "--install"], xdg.as_deref());
            assert!(o.status.success(), "{shell}: {}", stderr(&o));
            let said = String::from_utf8_lossy(&o.stdout);
            common::assert_mentions(&said, &[&want.display().to_string()]);
            assert_eq!(std::fs::read(&want).unwrap(), script(shell), "{shell}");
        }
        // Nothing but the script in its folder (no temporary file left).
        let n = std::fs::read_dir(want.parent().unwrap()).unwrap().count();
        assert_eq!(n, 1, "{shell}");
    }
    // No known place, or no HOME: bad input, nothing written.
    let o = run(&["completions", "elvish", "--install"], None);
    assert_eq!(o.status.code(), Some(2));
    common::assert_mentions(&stderr(&o), &["elvish"]);
    let o = bin()
        .args(["completions", "bash", "--install"])
        .env_remove("HOME")
        .env_remove("XDG_DATA_HOME")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
