//! A process of the soak (the loop, a planner, the bridge): its output in a log file of the
//! run's folder, in a process group of its own so that Ctrl-C reaches the soak alone (which
//! then stops its children in order), and killed by the kernel should the soak die first.

use super::SoakError;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// A child process; stopped ([`Proc::stop`], 5 s of grace) if still running when dropped.
#[derive(Debug)]
pub struct Proc {
    child: Child,
    /// What it is, for messages (`loop`, `local-planner-3`, ...).
    pub name: String,
    /// Its log (standard output and error).
    pub log: PathBuf,
    exit: Option<ExitStatus>,
}

impl Proc {
    /// Starts `cmd` as `name`, its output into `dir/name.log`.
    pub fn spawn(mut cmd: Command, dir: &Path, name: &str) -> Result<Self, SoakError> {
        let log = dir.join(format!("{name}.log"));
        let what = format!("{name} ({cmd:?})");
        let out = std::fs::File::create(&log).map_err(|error| SoakError::Io {
            what: format!("creating {}", log.display()),
            error,
        })?;
        let err = out.try_clone().map_err(|error| SoakError::Io {
            what: format!("opening {}", log.display()),
            error,
        })?;
        cmd.stdin(Stdio::null())
            .stdout(out)
            .stderr(err)
            .process_group(0);
        // SAFETY: runs in the child between fork and exec; prctl(2) is async-signal-safe,
        // and the closure allocates nothing and takes no lock.
        unsafe {
            cmd.pre_exec(|| {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = cmd
            .spawn()
            .map_err(|error| SoakError::Start { what, error })?;
        Ok(Proc {
            child,
            name: name.to_owned(),
            log,
            exit: None,
        })
    }

    /// Its process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Its exit status once it has ended (reaping it), `None` while it runs.
    pub fn exited(&mut self) -> Option<ExitStatus> {
        if self.exit.is_none() {
            self.exit = self.child.try_wait().ok().flatten();
        }
        self.exit
    }

    /// Sends `signal` while it runs (never to a reaped, possibly reused, pid).
    pub fn signal(&mut self, signal: i32) {
        if self.exited().is_none() {
            // SAFETY: kill(2) on our own child, not yet reaped.
            unsafe { libc::kill(self.child.id() as libc::pid_t, signal) };
        }
    }

    /// Waits up to `timeout` for it to end; its status if it did.
    pub fn wait_timeout(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let end = Instant::now() + timeout;
        loop {
            if let Some(s) = self.exited() {
                return Some(s);
            }
            if Instant::now() >= end {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// `kill -9`, and reaps it.
    pub fn kill(&mut self) -> Option<ExitStatus> {
        self.signal(libc::SIGKILL);
        self.wait_timeout(Duration::from_secs(10))
    }

    /// Asks it to stop as Ctrl-C would (`SIGCONT`, then `SIGTERM`: it writes its report),
    /// kills it after `grace`; its status, and whether it stopped within `grace`.
    pub fn stop(&mut self, grace: Duration) -> (Option<ExitStatus>, bool) {
        self.signal(libc::SIGCONT);
        self.signal(libc::SIGTERM);
        match self.wait_timeout(grace) {
            Some(s) => (Some(s), true),
            None => (self.kill(), false),
        }
    }

    /// The last `lines` lines of its log, for error messages.
    pub fn log_tail(&self, lines: usize) -> String {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let all: Vec<&str> = text.lines().collect();
        all[all.len().saturating_sub(lines)..].join("\n")
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if self.exited().is_none() {
            self.stop(Duration::from_secs(5));
        }
    }
}
