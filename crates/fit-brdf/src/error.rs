//! Errors of the command line: a cause chain plus the exit class.

use std::fmt::Display;

/// Why a command failed, which decides the exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// The user's input (a file, a value) is wrong: exit 2.
    BadInput,
    /// Something failed at run time (a write, a resource): exit 1.
    Runtime,
}

/// A failed command: what went wrong, with its causes.
#[derive(Debug)]
pub struct CliError {
    pub class: Class,
    pub error: anyhow::Error,
}

impl CliError {
    pub fn exit_code(&self) -> i32 {
        match self.class {
            Class::BadInput => 2,
            Class::Runtime => 1,
        }
    }

    /// Prints `error: <what>` and every cause on stderr. A cause whose text the
    /// message already contains (typed errors often quote their source) is not
    /// repeated.
    pub fn report(&self) {
        eprint!("{}", self.render());
    }

    /// The text [`report`](Self::report) prints.
    pub fn render(&self) -> String {
        let mut shown = self.error.to_string();
        let mut out = format!("error: {shown}\n");
        for cause in self.error.chain().skip(1) {
            let c = cause.to_string();
            if !shown.contains(&c) {
                out += &format!("  caused by: {c}\n");
                shown += &c;
            }
        }
        out
    }
}

/// Wraps an error as bad input (exit 2).
pub fn bad_input(e: impl Into<anyhow::Error>) -> CliError {
    CliError {
        class: Class::BadInput,
        error: e.into(),
    }
}

/// Wraps an error as a runtime failure (exit 1).
pub fn runtime(e: impl Into<anyhow::Error>) -> CliError {
    CliError {
        class: Class::Runtime,
        error: e.into(),
    }
}

/// A bad-input error from a message.
pub fn bad_msg(msg: impl Display) -> CliError {
    bad_input(anyhow::anyhow!("{msg}"))
}

pub type CliResult<T> = Result<T, CliError>;

/// The command-line spelling of a library setting: `sample_fraction` is
/// `--sample-fraction`.
pub fn flag(setting: &str) -> String {
    format!("--{}", setting.replace('_', "-"))
}

/// A model-list or settings error of the library, its settings named by their flags
/// (the library names them as settings: `fix`, `sample_fraction`); the causes are the
/// library error's own.
#[derive(Debug)]
pub struct Flagged(pub brdfkit::fit::families::FamilyError);

impl std::fmt::Display for Flagged {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0.message_with(&flag))
    }
}

impl std::error::Error for Flagged {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// A model-list or settings error as bad input (exit 2), named by flags.
pub fn bad_settings(e: brdfkit::fit::families::FamilyError) -> CliError {
    bad_input(Flagged(e))
}

/// A report setting the library refused, named by its flag (bad input, exit 2); any
/// other report error is a runtime failure.
pub fn bad_report_option(e: brdfkit_validate::html::ReportError) -> CliError {
    match e {
        brdfkit_validate::html::ReportError::Option { option, reason } => {
            bad_msg(format!("{}: {reason}", flag(option)))
        }
        e => runtime(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_errors_name_flags() {
        use brdfkit::fit::families::FamilyError;
        let e = FamilyError::Setting {
            option: "sample_fraction",
            reason: "0: must lie in (0, 1]".into(),
        };
        assert_eq!(e.to_string(), "sample_fraction: 0: must lie in (0, 1]");
        assert_eq!(
            bad_settings(e).render(),
            "error: --sample-fraction: 0: must lie in (0, 1]\n"
        );
        let e = FamilyError::ChoiceWithoutModel {
            options: vec!["distribution", "masking", "fresnel"],
            model: "cook-torrance",
        };
        assert_eq!(
            Flagged(e).to_string(),
            "--distribution, --masking and --fresnel apply to cook-torrance, which is not among the models"
        );
    }

    #[test]
    fn causes_already_quoted_are_not_repeated() {
        let io = std::io::Error::other("No such device");
        let e = runtime(anyhow::Error::new(io).context("t.binary: opening: No such device"));
        assert_eq!(e.render(), "error: t.binary: opening: No such device\n");
        let e = bad_input(anyhow::anyhow!("root cause").context("t.binary: cannot read"));
        assert_eq!(
            e.render(),
            "error: t.binary: cannot read\n  caused by: root cause\n"
        );
    }
}
