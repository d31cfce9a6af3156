//! The one loop every process of the set runs. It owns what the five processes share:
//! the control stream and the neighbours' progress (`Link::poll`), idling until a
//! neighbour's wake-up, heartbeats, the checkpoint hook that moves the resume tick,
//! and the linger after the last tick. A process says only what one pass does
//! (`Service::turn`); the stage's tick itself is `stage::Stage::process`.

use super::{Exit, Link, ProcessError};
use crate::sim::msg::STATE_DONE;
use std::time::Duration;

/// What one pass of a process did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Turn {
    /// Did work: go round again at once.
    Busy,
    /// Nothing to do: sleep until a neighbour's wake-up, or this long at most.
    Idle(Duration),
    /// Sleep exactly this long (a real-time tick not yet due).
    Wait(Duration),
    /// The campaign is done here: report it and wait for the supervisor's stop.
    Done,
}

/// A process of the set, as the loop drives it.
pub trait Service {
    /// One pass: take what has arrived, publish what the credit allows. Progress goes
    /// into `link.progress` (`next_tick`, `state`, counters); the loop beats for it.
    fn turn(&mut self, link: &mut Link) -> Result<Turn, ProcessError>;

    /// Checkpoint hook: the tick this process could resume from after a restart, when
    /// it has moved (a checkpoint reached the disk). Upstream keeps samples from it on.
    fn resume_tick(&mut self) -> Option<u64> {
        None
    }

    /// On the way out, whatever the exit: flush files, drain outboxes.
    fn stop(&mut self, _link: &mut Link, _exit: Exit) -> Result<(), ProcessError> {
        Ok(())
    }
}

/// Run `service` on `link` until the supervisor says stop or the process is signalled.
pub fn drive(link: &mut Link, service: &mut impl Service) -> Result<Exit, ProcessError> {
    link.beat()?;
    let mut beat_block = link.progress.next_tick / crate::tuning::BEAT_TICKS;
    let exit = loop {
        if let Some(e) = link.poll()? {
            break e;
        }
        // The writer may finish while the process waits for input, and the upstream
        // may be waiting for exactly this news (its ring full): look on every pass.
        if let Some(r) = service.resume_tick() {
            if r != link.progress.resume_tick {
                link.progress.resume_tick = r;
                link.beat()?;
            }
        }
        let turn = service.turn(link)?;
        let block = link.progress.next_tick / crate::tuning::BEAT_TICKS;
        if block != beat_block {
            beat_block = block;
            link.beat()?;
        }
        let out = match turn {
            Turn::Busy => None,
            Turn::Idle(d) => link.idle(d),
            Turn::Wait(d) => link.sleep(d),
            Turn::Done => Some(link.linger(STATE_DONE)?),
        };
        if let Some(e) = out {
            break e;
        }
    };
    service.stop(link, exit)?;
    Ok(exit)
}
