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

#[cfg(test)]
mod tests {
    use super::*;

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
