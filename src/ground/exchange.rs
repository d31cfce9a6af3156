//! When a telecommand's exchange is over, from the telemetry that comes back: its
//! verification reports (matched by request ID: the telecommand's first 4 bytes) up to
//! the last one its acknowledgement flags asked for, and the data report that answers
//! it (17,2 a ping, 20,2 a parameter request, 3,25 of each structure 3,27 asked for).
//! A failure report of any stage ends it at once.

use super::client::{Sent, ACK_ACCEPTANCE, ACK_COMPLETION, ACK_START};
use super::describe::Described;
use super::tc::Reply;
use serde_json::Value;

/// How an exchange ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Every report asked for came, and the data reply.
    Done,
    /// A failure report: its subtype (2, 4, 6, 8) and failure code, with the code's
    /// name and meaning from the dictionary.
    Failed {
        subtype: u8,
        code: u16,
        name: String,
        meaning: String,
    },
}

/// An exchange that nothing could end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("--ack asks for no acceptance, start or completion report and this telecommand has no data reply: nothing would end the exchange")]
pub struct NothingEnds;

/// An exchange under way.
#[derive(Debug, Clone)]
pub struct Exchange {
    request_id: [u8; 4],
    ack: u8,
    heard: bool,
    accepted: bool,
    started: bool,
    completed: bool,
    reply: Reply,
    reply_done: bool,
    /// The structures whose 3,25 is still awaited (`Reply::Housekeeping`).
    structures_left: Vec<u16>,
}

impl Exchange {
    /// Would anything end an exchange asking for the reports of `ack_flags`?
    pub fn check(ack_flags: u8, reply: &Reply) -> Result<(), NothingEnds> {
        let stages = ACK_ACCEPTANCE | ACK_START | ACK_COMPLETION;
        if ack_flags & stages == 0 && *reply == Reply::None {
            return Err(NothingEnds);
        }
        Ok(())
    }

    pub fn new(sent: &Sent, reply: Reply) -> Result<Exchange, NothingEnds> {
        Exchange::check(sent.ack_flags, &reply)?;
        let structures_left = match &reply {
            Reply::Housekeeping(ids) => ids.clone(),
            _ => Vec::new(),
        };
        Ok(Exchange {
            request_id: sent.request_id,
            ack: sent.ack_flags,
            heard: false,
            accepted: false,
            started: false,
            completed: false,
            reply_done: reply == Reply::None,
            reply,
            structures_left,
        })
    }

    /// Has any datagram come?
    pub fn heard(&self) -> bool {
        self.heard
    }

    /// Is this verification report about our telecommand?
    fn ours(&self, v: &Value) -> bool {
        let field = |k: &str| {
            v.get("request")
                .and_then(|r| r.get(k))
                .and_then(Value::as_u64)
        };
        let id = u16::from_be_bytes([self.request_id[0], self.request_id[1]]);
        let ctl = u16::from_be_bytes([self.request_id[2], self.request_id[3]]);
        field("packet_id") == Some(id.into()) && field("sequence_control") == Some(ctl.into())
    }

    /// Takes one datagram; the outcome once the exchange is over.
    pub fn take(&mut self, d: &Described) -> Option<Outcome> {
        self.heard = true;
        let v = &d.value;
        let service = v.get("service").and_then(Value::as_u64);
        let subtype = v.get("subtype").and_then(Value::as_u64).unwrap_or(0) as u8;
        if d.is_error() {
            return None;
        }
        match service {
            Some(1) if self.ours(v) => {
                if subtype % 2 == 0 {
                    let f = v.get("failure");
                    let text = |k: &str| {
                        f.and_then(|f| f.get(k))
                            .and_then(Value::as_str)
                            .unwrap_or("?")
                            .to_string()
                    };
                    return Some(Outcome::Failed {
                        subtype,
                        code: f
                            .and_then(|f| f.get("code"))
                            .and_then(Value::as_u64)
                            .unwrap_or(0) as u16,
                        name: text("name"),
                        meaning: text("meaning"),
                    });
                }
                match subtype {
                    1 => self.accepted = true,
                    3 => self.started = true,
                    7 => self.completed = true,
                    _ => {}
                }
            }
            Some(17) if self.reply == Reply::Pong => self.reply_done = true,
            Some(20) if self.reply == Reply::Parameters => self.reply_done = true,
            Some(3) if self.accepted || self.ack & ACK_ACCEPTANCE == 0 => {
                let id = v.get("structure").and_then(Value::as_u64);
                self.structures_left.retain(|s| Some(u64::from(*s)) != id);
                if matches!(self.reply, Reply::Housekeeping(_)) && self.structures_left.is_empty() {
                    self.reply_done = true;
                }
            }
            _ => {}
        }
        let verified = if self.ack & ACK_COMPLETION != 0 {
            self.completed
        } else if self.ack & ACK_START != 0 {
            self.started
        } else if self.ack & ACK_ACCEPTANCE != 0 {
            self.accepted
        } else {
            true
        };
        (verified && self.reply_done).then_some(Outcome::Done)
    }

    /// What is still awaited, for a timeout's message.
    pub fn awaited(&self) -> String {
        let mut w = Vec::new();
        if self.ack & ACK_ACCEPTANCE != 0 && !self.accepted {
            w.push("the acceptance report (1,1)");
        }
        if self.ack & ACK_START != 0 && !self.started {
            w.push("the start report (1,3)");
        }
        if self.ack & ACK_COMPLETION != 0 && !self.completed {
            w.push("the completion report (1,7)");
        }
        if !self.reply_done {
            w.push(match self.reply {
                Reply::Pong => "the test report (17,2)",
                Reply::Parameters => "the parameter report (20,2)",
                _ => "the housekeeping reports (3,25)",
            });
        }
        w.join(", ")
    }
}

/// Keeps the telemetry coming to a link's socket: telemetry goes to the sender of the
/// last accepted telecommand, so a listener pings (17,1, no reports asked for: only the
/// 17,2 and a failure come back) at start and every `every` (zero: only at start).
#[derive(Debug)]
pub struct Keepalive {
    every: std::time::Duration,
    next: Option<std::time::Instant>,
    last: Option<Exchange>,
}

impl Keepalive {
    pub fn new(every: std::time::Duration) -> Keepalive {
        Keepalive {
            every,
            next: Some(std::time::Instant::now()),
            last: None,
        }
    }

    /// Pings when it is time; the time of the next ping (None: no more).
    pub fn tick(
        &mut self,
        link: &mut super::client::Link,
    ) -> Result<Option<std::time::Instant>, super::client::ClientError> {
        let now = std::time::Instant::now();
        if self.next.is_some_and(|at| now >= at) {
            let sent = link.send(17, 1, 0, &[])?;
            self.last = Exchange::new(&sent, Reply::Pong).ok();
            self.next = (!self.every.is_zero()).then(|| now + self.every);
        }
        Ok(self.next)
    }

    /// A failure report of the last ping (its key is wrong, say), if this is one.
    pub fn refusal(&mut self, d: &Described) -> Option<Outcome> {
        match self.last.as_mut().and_then(|x| x.take(d)) {
            Some(f @ Outcome::Failed { .. }) => Some(f),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::client::ACK_ALL;
    use serde_json::json;

    fn sent(ack: u8) -> Sent {
        Sent {
            request_id: [0x19, 0x20, 0xC0, 0x05],
            seq: 1,
            service: 17,
            subtype: 1,
            ack_flags: ack,
            packet: Vec::new(),
        }
    }

    fn report(subtype: u8, seq_ctl: u16, failure: Option<u16>) -> Described {
        let mut v = json!({"service": 1, "subtype": subtype,
            "request": {"packet_id": 0x1920, "sequence_control": seq_ctl}});
        if let Some(c) = failure {
            v["failure"] = json!({"code": c, "name": "bad_mac", "meaning": "m"});
        }
        Described {
            value: v,
            text: String::new(),
        }
    }

    fn data(service: u8, subtype: u8, structure: Option<u16>) -> Described {
        let mut v = json!({"service": service, "subtype": subtype});
        if let Some(s) = structure {
            v["structure"] = json!(s);
        }
        Described {
            value: v,
            text: String::new(),
        }
    }

    #[test]
    fn a_ping_ends_at_its_completion_and_its_pong() {
        let mut x = Exchange::new(&sent(ACK_ALL), Reply::Pong).unwrap();
        assert!(!x.heard());
        // Another request's report does not count.
        assert_eq!(x.take(&report(7, 0xC004, None)), None);
        assert!(x.heard());
        assert_eq!(x.take(&report(1, 0xC005, None)), None);
        assert_eq!(x.take(&data(17, 2, None)), None);
        assert_eq!(
            x.awaited(),
            "the start report (1,3), the completion report (1,7)"
        );
        assert_eq!(x.take(&report(3, 0xC005, None)), None);
        assert_eq!(x.take(&report(7, 0xC005, None)), Some(Outcome::Done));
    }

    #[test]
    fn a_failure_ends_it_and_without_completion_acceptance_does() {
        let mut x = Exchange::new(&sent(ACK_ALL), Reply::None).unwrap();
        assert_eq!(x.take(&report(2, 0xC004, Some(11))), None);
        assert!(matches!(
            x.take(&report(2, 0xC005, Some(11))),
            Some(Outcome::Failed {
                subtype: 2,
                code: 11,
                ..
            })
        ));
        let mut x = Exchange::new(&sent(ACK_ACCEPTANCE), Reply::Parameters).unwrap();
        assert_eq!(x.take(&report(1, 0xC005, None)), None);
        assert_eq!(x.take(&data(20, 2, None)), Some(Outcome::Done));
        let mut x = Exchange::new(&sent(0), Reply::Pong).unwrap();
        assert_eq!(x.take(&data(17, 2, None)), Some(Outcome::Done));
        assert!(Exchange::new(&sent(0), Reply::None).is_err());
    }

    #[test]
    fn one_report_now_waits_for_each_structure_after_the_acceptance() {
        let mut x = Exchange::new(&sent(ACK_ACCEPTANCE), Reply::Housekeeping(vec![1, 2])).unwrap();
        // A periodic report before the acceptance is not the answer.
        assert_eq!(x.take(&data(3, 25, Some(1))), None);
        assert_eq!(x.take(&report(1, 0xC005, None)), None);
        assert_eq!(x.take(&data(3, 25, Some(2))), None);
        assert_eq!(x.take(&data(3, 25, Some(1))), Some(Outcome::Done));
    }
}
