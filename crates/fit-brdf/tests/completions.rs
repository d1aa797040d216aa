//! `fit-brdf completions SHELL`: a completion script for every shell clap_complete knows,
//! listing every subcommand; and the help conventions of batch, export and completions.

mod common;

use common::bin;

/// The subcommands as `fit-brdf --help` lists them (so a new one is checked too).
fn subcommands() -> Vec<String> {
    let o = bin().arg("--help").output().unwrap();
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
    let o = bin().args(["completions", "bash"]).output().unwrap();
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
        let o = bin().args(["completions", shell]).output().unwrap();
        assert!(o.status.success(), "{shell}");
        let s = String::from_utf8(o.stdout).unwrap();
        assert!(s.contains(marker), "{shell}: {}", &s[..s.len().min(200)]);
        assert!(s.contains("batch") && s.contains("export"), "{shell}");
    }
    let o = bin().args(["completions", "tcsh"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let o = bin().arg("completions").output().unwrap();
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn batch_export_and_completions_show_examples_in_their_help() {
    for sub in ["batch", "export", "completions"] {
        let o = bin().args([sub, "--help"]).output().unwrap();
        assert!(o.status.success(), "{sub}");
        let h = String::from_utf8(o.stdout).unwrap();
        assert!(
            h.contains("Examples:") && h.contains(&format!("fit-brdf {sub} ")),
            "{sub}: {h}"
        );
    }
}
