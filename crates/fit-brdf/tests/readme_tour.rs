//! The README runs as written (issue 30): its shell examples are extracted, run
//! verbatim by bash in a scratch copy of the checkout with `fit-brdf` (this build's) on
//! the `PATH`, and the outputs it quotes are compared with what the commands print.
//! The same for docs/scoring.md's worked example.
//!
//! The rules, the whole of them (no list of exceptions):
//!
//! - **Which blocks run.** Every fenced block of the page (from a given heading on, for
//!   a page whose first part is loose examples) whose info string is `sh`, `bash` or
//!   `shell`, in the page's order, in one bash session, as a reader pasting them one
//!   after the other does (a `cd` in one block holds for the next), starting at the
//!   checkout's root. A block that runs `cargo` is skipped: it builds, installs or tests
//!   brdfkit, which is what this test is (cargo built the `fit-brdf` under test and the
//!   harness puts it on the `PATH`, which is what the README's install block does); its
//!   alternative lines (`alias fit-brdf=…   # or …`) go with it.
//! - **Files the page shows.** Another block whose introducing sentence ends with a file
//!   name, `` `NAME`: ``, is that file: written where the session is, at that point.
//! - **Which lines are commands.** Every line but blank ones and comments (`#` first:
//!   bash skips them too, so commented alternatives such as `#   fit-brdf eval … .npy`
//!   stay as they are); a line ending in `\` continues on the next, a here-document
//!   (`<<WORD`) up to its `WORD` line. Each command runs verbatim, its output (stdout and
//!   stderr, interleaved as on a terminal) captured; the run stops at the first command
//!   that fails.
//! - **What fails.** A command's exit status other than 0, or than N when the page says
//!   `# exit N` after it; an output line that reports an error ([`error_line`]) from a
//!   command meant to succeed; a session that stops early (a line bash cannot parse, or
//!   over [`SESSION_LIMIT`]).
//! - **Quoted outputs.** In a ```` ```text ```` block, a line `$ COMMAND` quotes what
//!   `COMMAND` prints, up to the next `$ ` line or the block's end; a text block without
//!   `$ ` lines right after a shell block that runs (nothing but blank lines between)
//!   quotes that block's last command. The command must be one the page ran (the quote
//!   of a line that left the tour fails), and its output must match
//!   ([`matches_quote`]): a line starting with `...` (a remark may follow) stands for any
//!   number of lines, `...` inside a line for any text; runs of spaces match any run
//!   (column widths move with the numbers); numbers agree to a relative 1e-3 (round-off
//!   below 1e-12 is zero), apart from timings: a number followed by a unit of time (`s`,
//!   `ms`) or printed under a column heading one ([`is_timing`]).
//!
//! Pages covered: README.md, whole (the tour, the glTF example, and whatever shell
//! blocks are added to it); docs/scoring.md from its worked example on. docs/python.md's
//! worked example is run as written by `crates/brdfkit-python/tests/test_docs.py`
//! (pytest, under `cargo test -p brdfkit-python`, a `python_package_test!`). Not
//! covered: the loose examples of the other pages, on placeholder files
//! (`table.binary`, `merl/`, `a.json`), and maintainer runs of hours.
//!
//! The test build's `fit-brdf` is the dev profile (opt-level 1, dependencies at 3):
//! the tour takes about two minutes of CPU (docs/performance.md, "The README's
//! figures, and its tour").

use regex::Regex;
use std::fmt::Write as _;
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// How long one page's session may run: the README's takes about 4 minutes in the
/// test build on a loaded 2-core machine (docs/performance.md).
const SESSION_LIMIT: Duration = Duration::from_secs(20 * 60);

/// The workspace root.
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A fenced block of a Markdown page.
#[derive(Debug, Clone)]
struct Block {
    /// The info string's first word (`sh`, `text`, …).
    lang: String,
    /// The page's line number of the opening fence.
    line: usize,
    /// The lines between the fences.
    lines: Vec<String>,
    /// The last line of prose between the previous block and this one ("" when only
    /// blank lines separate them).
    before: String,
}

/// Every fenced block (```` ``` ```` or `~~~`, not indented) of a page.
fn blocks(page: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<(String, Block)> = None;
    let mut before = String::new();
    for (k, line) in page.lines().enumerate() {
        let fence = ["```", "~~~"].into_iter().find(|f| line.starts_with(f));
        match (&mut open, fence) {
            (Some((f, _)), Some(g)) if f == g && line.trim_end() == g => {
                out.push(open.take().unwrap().1);
            }
            (Some((_, b)), _) => b.lines.push(line.to_string()),
            (None, Some(f)) => {
                let lang = line[f.len()..].split_whitespace().next().unwrap_or("");
                open = Some((
                    f.to_string(),
                    Block {
                        lang: lang.to_string(),
                        line: k + 1,
                        lines: Vec::new(),
                        before: std::mem::take(&mut before),
                    },
                ));
            }
            (None, None) if !line.trim().is_empty() => before = line.trim().to_string(),
            (None, None) => {}
        }
    }
    out
}

/// One command of a block: its first line's number in the page and its text.
#[derive(Debug, Clone, PartialEq)]
struct Cmd {
    line: usize,
    text: String,
    /// The exit status the page says it has (`# exit N` after it), else 0.
    exit: i32,
}

/// The commands of a shell block (see the module's rules).
fn commands(b: &Block) -> Vec<Cmd> {
    let heredoc = Regex::new(r#"<<-?\s*['"]?([A-Za-z_][A-Za-z0-9_]*)['"]?"#).unwrap();
    let exit = Regex::new(r"\s#\s*exit\s+(\d+)\b").unwrap();
    let mut out: Vec<Cmd> = Vec::new();
    let mut lines = b.lines.iter().enumerate();
    while let Some((k, first)) = lines.next() {
        let t = first.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let mut text = first.clone();
        while text.ends_with('\\') {
            match lines.next() {
                Some((_, l)) => write!(text, "\n{l}").unwrap(),
                None => break,
            }
        }
        if let Some(c) = heredoc.captures(&text) {
            let end = c[1].to_string();
            for (_, l) in lines.by_ref() {
                write!(text, "\n{l}").unwrap();
                if l.trim() == end {
                    break;
                }
            }
        }
        let exit = exit.captures(first).map_or(0, |c| c[1].parse().unwrap());
        out.push(Cmd {
            line: b.line + 1 + k,
            text,
            exit,
        });
    }
    out
}

/// Whether a block runs (see the module's rules): a shell block that runs no `cargo`.
fn runs(b: &Block, cmds: &[Cmd]) -> bool {
    let cargo = Regex::new(r"(^|[;&|(]\s*)cargo\s").unwrap();
    shell(b) && !cmds.iter().any(|c| cargo.is_match(c.text.trim_start()))
}

/// The command that writes a file the page shows as a block: one (not a shell block)
/// whose introducing sentence ends with the file's name, `` `NAME`: `` (docs/scoring.md:
/// "… gives `published.json`:").
fn file_command(b: &Block) -> Option<Cmd> {
    let name = Regex::new(r"`([\w.-]+\.\w+)`:$").unwrap();
    let file = name.captures(&b.before)?[1].to_string();
    (!shell(b)).then(|| Cmd {
        line: b.line,
        text: format!(
            "cat > '{file}' <<'PAGE_FILE_END'\n{}\nPAGE_FILE_END",
            b.lines.join("\n")
        ),
        exit: 0,
    })
}

/// Whether a block is a shell block.
fn shell(b: &Block) -> bool {
    matches!(b.lang.as_str(), "sh" | "bash" | "shell")
}

/// A quoted output: the command after `$ ` and the lines quoted under it.
#[derive(Debug, Clone)]
struct Quote {
    line: usize,
    cmd: String,
    /// The page line of the command quoted, when the quote follows its block.
    at: Option<usize>,
    lines: Vec<String>,
}

/// The quotes of a page's ```` ```text ```` blocks: `$ ` lines, or a whole block right
/// after a shell block that runs, quoting that block's last command.
fn quotes(page: &[Block]) -> Vec<Quote> {
    let mut out: Vec<Quote> = Vec::new();
    for (i, b) in page.iter().enumerate().filter(|(_, b)| b.lang == "text") {
        let last = match i.checked_sub(1).map(|p| (&page[p], commands(&page[p]))) {
            Some((p, c)) if b.before.is_empty() && runs(p, &c) => c.last().cloned(),
            _ => None,
        };
        let whole = !b.lines.iter().any(|l| l.starts_with("$ "));
        let mut current = last.filter(|_| whole).map(|c| Quote {
            line: b.line,
            cmd: c.text,
            at: Some(c.line),
            lines: Vec::new(),
        });
        for (k, l) in b.lines.iter().enumerate() {
            if let Some(cmd) = l.strip_prefix("$ ") {
                out.extend(current.take());
                current = Some(Quote {
                    line: b.line + 1 + k,
                    cmd: cmd.trim().to_string(),
                    at: None,
                    lines: Vec::new(),
                });
            } else if let Some(q) = &mut current {
                q.lines.push(l.clone());
            }
        }
        out.extend(current);
    }
    for q in &mut out {
        while q.lines.last().is_some_and(|l| l.trim().is_empty()) {
            q.lines.pop();
        }
    }
    out
}

/// An output line that reports an error: one starting with `error` (any case; Rust's
/// `Error: …` of a failed `main`, clap's `error: …`), a panic, or a Python traceback.
fn error_line(line: &str) -> bool {
    let t = line.trim_start().to_ascii_lowercase();
    t.starts_with("error") || line.contains("panicked at") || t.starts_with("traceback (")
}

/// What a page's run gave: every command run, with its output and exit status.
#[derive(Debug)]
struct Ran {
    cmd: Cmd,
    output: String,
    status: i32,
}

/// The bash script of a page: each command verbatim inside `{ … }` (so its own
/// redirections, `cd` and variables hold), its output to `N.out`, its status to
/// `N.rc`; the first failure ends the script.
fn script(cmds: &[Cmd], logs: &Path) -> String {
    let mut s = String::from("set -o pipefail\n");
    for (n, c) in cmds.iter().enumerate() {
        let log = logs.join(n.to_string());
        let log = log.display();
        writeln!(
            s,
            "{{\n{}\n}} >'{log}.out' 2>&1 </dev/null\nrc=$?\necho $rc >'{log}.rc'\n\
             [ $rc -eq {} ] || exit 0",
            c.text, c.exit
        )
        .unwrap();
    }
    s
}

/// A scratch checkout: every top-level entry of the workspace linked (the README's
/// inputs are read, never written), but `target/`, `.git` and the tour's own folder.
fn scratch_checkout(root: &Path) {
    for e in std::fs::read_dir(workspace()).unwrap() {
        let e = e.unwrap();
        let name = e.file_name();
        if matches!(name.to_str(), Some("target" | ".git" | "tour")) {
            continue;
        }
        std::os::unix::fs::symlink(e.path().canonicalize().unwrap(), root.join(&name)).unwrap();
    }
}

/// Runs `cmds` in one bash session at `root` with `fit-brdf` on the `PATH` and a home
/// of its own (`completions --install` writes there); returns what ran.
fn run_session(root: &Path, cmds: &[Cmd]) -> Vec<Ran> {
    let logs = root.join(".tour-logs");
    let bin = root.join(".tour-bin");
    let home = root.join(".tour-home");
    for d in [&logs, &bin, &home] {
        std::fs::create_dir_all(d).unwrap();
    }
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_fit-brdf"), bin.join("fit-brdf")).unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    // The exit status says nothing: the script ends with 0 after a failed command, and a
    // line bash cannot parse shows as the session stopping early. A command that waits
    // (a server, a prompt) is stopped at the limit, with everything it started.
    let mut child = Command::new("bash")
        .arg("-c")
        .arg(script(cmds, &logs))
        .current_dir(root)
        .env("PATH", path)
        .env("HOME", &home)
        .env_remove("XDG_DATA_HOME")
        .env_remove("XDG_CONFIG_HOME")
        .env_remove("BRDFKIT_MEASURED_DIR")
        .stderr(std::fs::File::create(logs.join("bash.err")).unwrap())
        .process_group(0)
        .spawn()
        .expect("bash runs");
    let start = Instant::now();
    while child.try_wait().expect("bash runs").is_none() {
        if start.elapsed() > SESSION_LIMIT {
            // SAFETY: kill(2) on the process group this test made; no memory involved.
            unsafe { libc::kill(-(child.id() as i32), libc::SIGKILL) };
            let _ = child.wait();
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let mut out = Vec::new();
    for (n, c) in cmds.iter().enumerate() {
        let Ok(rc) = std::fs::read_to_string(logs.join(format!("{n}.rc"))) else {
            break;
        };
        out.push(Ran {
            cmd: c.clone(),
            output: std::fs::read_to_string(logs.join(format!("{n}.out"))).unwrap_or_default(),
            status: rc.trim().parse().unwrap_or(-1),
        });
    }
    out
}

/// A piece of a quoted line.
#[derive(Debug, Clone, PartialEq)]
enum Tok {
    /// `...` (or `…`): any text.
    Any,
    /// A number, and whether a unit of time follows it.
    Num(String, bool),
    /// A run of spaces: any run.
    Space,
    /// Text, matched as it is.
    Text(String),
}

/// A quoted line's pieces. Digits right after a letter (`l2`, `fc1`, `summary-2`) are
/// text, not numbers.
fn tokens(q: &str) -> Vec<Tok> {
    let token =
        Regex::new(r"(\.\.\.|…)|([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)|(\s+)|([^\s.\d+-]+|.)")
            .unwrap();
    let unit = Regex::new(r"^\s*(s|ms|µs)\b").unwrap();
    let mut out = Vec::new();
    let mut after_word = false;
    for c in token.captures_iter(q) {
        let whole = c.get(0).unwrap();
        let t = if c.get(1).is_some() {
            Tok::Any
        } else if c.get(2).is_some() && !after_word {
            Tok::Num(whole.as_str().into(), unit.is_match(&q[whole.end()..]))
        } else if c.get(3).is_some() {
            Tok::Space
        } else {
            Tok::Text(whole.as_str().into())
        };
        after_word = match (&t, c.get(4)) {
            (_, Some(w)) => w.as_str().ends_with(char::is_alphanumeric),
            (Tok::Text(_), None) => after_word,
            _ => false,
        };
        out.push(t);
    }
    out
}

/// A quoted line as a pattern: its numbers captured, in order.
fn line_pattern(toks: &[Tok]) -> Regex {
    let mut re = String::from(r"^\s*");
    for t in toks {
        re.push_str(&match t {
            Tok::Any => ".*?".into(),
            Tok::Num(..) => r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|NaN|nan|inf)".into(),
            Tok::Space => r"\s+".into(),
            Tok::Text(x) => regex::escape(x),
        });
    }
    re.push_str(r"\s*$");
    Regex::new(&re).unwrap()
}

/// Whether the value at chars `[a, b)` of an output line sits under a heading (the
/// output line `header`) that names a unit of time or a time (`time s`, `setup ms`,
/// `wall ms (est)`).
fn is_timing(header: Option<&str>, a: usize, b: usize) -> bool {
    let Some(h) = header else { return false };
    let word = Regex::new(r"\S+").unwrap();
    word.find_iter(h).any(|w| {
        let (wa, wb) = (h[..w.start()].chars().count(), h[..w.end()].chars().count());
        wa < b && a < wb && matches!(w.as_str(), "s" | "ms" | "µs" | "time" | "(est)")
    })
}

/// Whether two printed numbers agree (see the module's rules).
fn same_number(want: &str, got: &str) -> bool {
    if want == got {
        return true;
    }
    match (want.parse::<f64>(), got.parse::<f64>()) {
        (Ok(x), Ok(y)) => {
            (x.abs() < 1e-12 && y.abs() < 1e-12) || (x - y).abs() <= 1e-3 * x.abs().max(y.abs())
        }
        _ => false,
    }
}

/// Checks one output line against one quoted line; `header` is the output line that
/// matched the quote's last line without numbers (a table's headings).
fn line_matches(quoted: &str, got: &str, header: Option<&str>) -> Result<(), String> {
    let toks = tokens(quoted);
    let c = line_pattern(&toks)
        .captures(got)
        .ok_or_else(|| format!("text differs:\n  quoted: {quoted}\n  output: {got}"))?;
    let nums = toks.iter().filter_map(|t| match t {
        Tok::Num(n, unit) => Some((n, *unit)),
        _ => None,
    });
    for (k, (want, unit)) in nums.enumerate() {
        let m = c.get(k + 1).unwrap();
        let (a, b) = (
            got[..m.start()].chars().count(),
            got[..m.end()].chars().count(),
        );
        if !unit && !is_timing(header, a, b) && !same_number(want, m.as_str()) {
            return Err(format!(
                "{want} printed as {}:\n  quoted: {quoted}\n  output: {got}",
                m.as_str()
            ));
        }
    }
    Ok(())
}

/// Whether a command's output matches its quote (see the module's rules): quoted lines
/// in order, `...` lines skipping any number of output lines, nothing left over unless
/// the quote ends with `...`.
fn matches_quote(quoted: &[String], output: &str) -> Result<(), String> {
    let got: Vec<&str> = output.lines().collect();
    let (mut j, mut skip, mut header) = (0, false, None::<&str>);
    for q in quoted {
        if q.trim_start().starts_with("...") || q.trim_start().starts_with('…') {
            skip = true;
            continue;
        }
        let has_numbers = tokens(q).iter().any(|t| matches!(t, Tok::Num(..)));
        let mut last = Err(format!("the output ended before: {q}"));
        while j < got.len() {
            last = line_matches(q, got[j], header);
            j += 1;
            if last.is_ok() || !skip {
                break;
            }
        }
        last.map_err(|e| format!("{e}\n(whole output:)\n{output}"))?;
        if !has_numbers {
            header = Some(got[j - 1]);
        }
        skip = false;
    }
    match got.get(j) {
        Some(extra) if !skip => Err(format!(
            "the output goes on after the quote ends (end the quote with `...`): {extra}\n\
             (whole output:)\n{output}"
        )),
        _ => Ok(()),
    }
}

/// What failed in a page's run, one paragraph per failure (empty: it runs as written).
fn check_page(name: &str, all: &[Block], root: &Path) -> (Vec<String>, usize, usize) {
    let cmds: Vec<Cmd> = all
        .iter()
        .flat_map(|b| {
            let c = commands(b);
            match file_command(b) {
                Some(f) => vec![f],
                None if runs(b, &c) => c,
                None => Vec::new(),
            }
        })
        .collect();
    let ran = run_session(root, &cmds);
    let bash_err = std::fs::read_to_string(root.join(".tour-logs/bash.err")).unwrap_or_default();
    let mut fails = Vec::new();
    for r in &ran {
        let at = format!("{name}:{}: `{}`", r.cmd.line, r.cmd.text);
        if r.status != r.cmd.exit {
            fails.push(format!("{at} exited with {}:\n{}", r.status, r.output));
        } else if let Some(l) = r.output.lines().find(|l| r.cmd.exit == 0 && error_line(l)) {
            fails.push(format!("{at} printed an error: {l}\n{}", r.output));
        }
    }
    if ran.len() < cmds.len() && fails.is_empty() {
        fails.push(format!(
            "{name}:{}: the session stopped at `{}` ({} of {} commands run): it ran over \
             {} s, or bash could not parse it: {bash_err}",
            cmds[ran.len()].line,
            cmds[ran.len()].text,
            ran.len(),
            cmds.len(),
            SESSION_LIMIT.as_secs()
        ));
    }
    let quoted = quotes(all);
    for q in &quoted {
        let norm = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
        let same = |r: &&Ran| {
            q.at.map_or(norm(&r.cmd.text) == norm(&q.cmd), |l| r.cmd.line == l)
        };
        match ran.iter().find(same) {
            // A session that stopped early has said so.
            None if ran.len() < cmds.len() => {}
            None => fails.push(format!(
                "{name}:{}: the quoted `{}` is not a command the page runs",
                q.line, q.cmd
            )),
            Some(r) => {
                if let Err(e) = matches_quote(&q.lines, &r.output) {
                    fails.push(format!(
                        "{name}:{}: the output of `{}` is not the quote: {e}",
                        q.line, q.cmd
                    ));
                }
            }
        }
    }
    (fails, cmds.len(), quoted.len())
}

/// Runs `page` (Markdown text) in a scratch checkout; returns the failures and the
/// numbers of commands and quotes. `from`: the heading the page's runnable part starts
/// at (None: the whole page).
fn run_page(name: &str, page: &str, from: Option<&str>) -> (Vec<String>, usize, usize) {
    let start = from.map_or(0, |h| {
        1 + page
            .lines()
            .position(|l| l.trim() == h)
            .unwrap_or_else(|| panic!("{name} has no heading `{h}`"))
    });
    let all: Vec<Block> = blocks(page)
        .into_iter()
        .filter(|b| b.line > start)
        .collect();
    let dir = tempfile::tempdir().unwrap();
    scratch_checkout(dir.path());
    check_page(name, &all, dir.path())
}

#[test]
fn the_readme_runs_as_written() {
    let page = std::fs::read_to_string(workspace().join("README.md")).unwrap();
    let (fails, ncmds, nquotes) = run_page("README.md", &page, None);
    assert!(fails.is_empty(), "{}", fails.join("\n\n"));
    // Not vacuous: the tour and the glTF example ran, and their quotes were compared.
    assert!(ncmds >= 20, "only {ncmds} commands found in README.md");
    assert!(
        nquotes >= 4,
        "only {nquotes} quoted outputs found in README.md"
    );
}

/// docs/scoring.md's worked example, from its heading on: a file the page shows
/// (`published.json`), a line meant to exit 2, outputs quoted under their blocks.
#[test]
fn the_scoring_worked_example_runs_as_written() {
    let page = std::fs::read_to_string(workspace().join("docs/scoring.md")).unwrap();
    let heading = "## Worked example: published metallic-roughness parameters";
    let (fails, ncmds, nquotes) = run_page("docs/scoring.md", &page, Some(heading));
    assert!(fails.is_empty(), "{}", fails.join("\n\n"));
    assert!(
        ncmds >= 9 && nquotes >= 4,
        "{ncmds} commands, {nquotes} quotes"
    );
}

/// The harness on pages written to fail: each way a README line can break is caught.
mod harness {
    use super::*;

    fn page(sh: &str, text: &str) -> String {
        format!("# t\n\n```sh\n{sh}\n```\n\nprints:\n\n```text\n{text}\n```\n")
    }

    fn fails(sh: &str, text: &str) -> Vec<String> {
        run_page("t.md", &page(sh, text), None).0
    }

    #[test]
    fn a_verb_that_changed_fails_the_page() {
        // An option the verb no longer has: exit 2.
        let f = fails(
            "fit-brdf synth ../data-synthetic/gold-ggx.toml --no-such-option x",
            "",
        );
        assert!(
            f.len() == 1 && f[0].contains("t.md:4") && f[0].contains("exited with 2"),
            "{f:?}"
        );
        // A missing input: the verb's own error.
        let f = fails("fit-brdf info no-such.binary", "");
        assert!(f.len() == 1 && f[0].contains("exited with 2"), "{f:?}");
        // A line bash cannot parse stops the session, and says where.
        let f = fails("true\nfi", "");
        assert!(f.len() == 1 && f[0].contains("stopped at `fi`"), "{f:?}");
        // The session stops at the first failure: later lines are not blamed.
        let f = fails("false\nfit-brdf info no-such.binary", "");
        assert!(
            f.len() == 1 && f[0].contains("`false` exited with 1"),
            "{f:?}"
        );
    }

    #[test]
    fn an_error_printed_with_exit_0_fails() {
        let f = fails("echo 'Error: no such file'", "");
        assert!(f.len() == 1 && f[0].contains("printed an error"), "{f:?}");
        assert!(fails("echo 'the error stated: 1e-3'", "").is_empty());
    }

    #[test]
    fn comments_cargo_blocks_and_state_follow_the_rules() {
        // Comments are not run; `cd` and files carry over between lines and blocks.
        let md = "```sh\nmkdir -p tour && cd tour\n# false\nprintf 'a\\n' > x.txt\n```\n\n\
                  ```sh\ncargo build --release\nfalse   # or an alternative\n```\n\n\
                  ```sh\ncat x.txt && test \"$(basename \"$PWD\")\" = tour\n```\n";
        let (f, n, _) = run_page("t.md", md, None);
        assert!(f.is_empty() && n == 3, "{f:?} {n}");
    }

    #[test]
    fn stale_quotes_fail_and_timings_do_not() {
        let sh = "printf 'model   loss   time s\\nct   1.5e-3   0.91\\nfitted in 2.0 s\\n'";
        // The same output, other timings, other column widths: it matches.
        assert!(
            fails(
                sh,
                &format!(
                    "$ {}\nmodel  loss  time s\nct  1.5e-3  7.25\nfitted in 9.9 s",
                    sh.trim()
                )
            )
            .is_empty()
        );
        // A loss that changed, a line that went, a line that came, a command not run.
        let q = |body: &str| fails(sh, &format!("$ {sh}\n{body}"));
        let f = q("model loss time s\nct 1.6e-3 0.91\n...");
        assert!(
            f.len() == 1 && f[0].contains("1.6e-3 printed as 1.5e-3"),
            "{f:?}"
        );
        let f = q("model loss time s\nct 1.5e-3 0.91\nconverged\nfitted in 2.0 s");
        assert!(f.len() == 1 && f[0].contains("text differs"), "{f:?}");
        let f = q("model loss time s");
        assert!(f.len() == 1 && f[0].contains("goes on after"), "{f:?}");
        let f = fails(sh, "$ fit-brdf info x.binary\nx");
        assert!(
            f.len() == 1 && f[0].contains("not a command the page runs"),
            "{f:?}"
        );
        // `...` lines and `...` inside a line.
        assert!(q("...\nfitted in ... s").is_empty());
    }

    #[test]
    fn files_expected_exits_and_quotes_under_a_block() {
        let md = "Some text gives `a.json`:\n\n```json\n{\"x\": 1}\n```\n\n\
                  ```sh\ncat a.json\nfalse   # exit 1: on purpose\nprintf 'one\\ntwo 2.0\\n'\n```\n\n\
                  ```text\n... (a remark)\ntwo 2.0\n```\n";
        let (f, n, q) = run_page("t.md", md, None);
        assert!(f.is_empty() && n == 4 && q == 1, "{f:?} {n} {q}");
        // The same quote with another number, or the purposeful failure gone: caught.
        let f = run_page("t.md", &md.replace("two 2.0\n```", "two 3.0\n```"), None).0;
        assert!(f.len() == 1 && f[0].contains("3.0 printed as 2.0"), "{f:?}");
        let f = run_page("t.md", &md.replace("false   #", "true   #"), None).0;
        assert!(f.len() == 1 && f[0].contains("exited with 0"), "{f:?}");
        // Only the part from the heading on runs.
        let md = format!("```sh\nfalse\n```\n\n## Part\n\n{md}");
        assert!(run_page("t.md", &md, Some("## Part")).0.is_empty());
    }

    #[test]
    fn numbers_after_letters_are_text() {
        assert_eq!(
            tokens("l2 fc1"),
            vec![
                Tok::Text("l".into()),
                Tok::Text("2".into()),
                Tok::Space,
                Tok::Text("fc".into()),
                Tok::Text("1".into())
            ]
        );
        assert!(matches!(tokens("0.00 s")[0], Tok::Num(_, true)));
        assert!(line_matches("shard 2/4 of 3", "shard 3/4 of 3", None).is_err());
    }
}
