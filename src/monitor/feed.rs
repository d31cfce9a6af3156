//! The monitor's ports on a run's bus: the estimates (published off the estimator's
//! loop thread) and the supervisor's status, read with queues of their own that
//! overflow safely when the monitor stalls, and the supervisor's request service. It
//! opens nothing a stage's loop publishes or reads, so attaching or detaching costs the
//! set nothing.

use crate::bus::{self, BusError};
use crate::msg::{EstimateMsg, Header, Request, SetStatus, REQ_STOP};
use crate::timing::monotonic_ns;
use iceoryx2::prelude::*;

/// Node name of every monitor (the supervisor does not take it for a stray stage).
pub const NODE: &str = bus::MONITOR_NODE;

pub struct Feed {
    estimates: bus::Sub<EstimateMsg>,
    status: bus::Sub<SetStatus>,
    requests: bus::Pub<Request>,
    seq: u64,
    /// Last field: dropped after the ports.
    _node: Node<ipc::Service>,
}

impl Feed {
    /// Attach to the run on `prefix`, if one is there (its supervisor made the status
    /// service); None otherwise, having made nothing on the bus.
    pub fn attach(prefix: &str) -> Result<Option<Feed>, BusError> {
        if !bus::service_exists(prefix, bus::SVC_STATUS) {
            return Ok(None);
        }
        let node = bus::node(NODE, prefix)?;
        let estimates = bus::subscriber::<EstimateMsg>(&node, bus::SVC_ESTIMATE)?;
        let status = bus::subscriber::<SetStatus>(&node, bus::SVC_STATUS)?;
        let requests = bus::publisher::<Request>(&node, bus::SVC_REQUEST)?;
        Ok(Some(Feed {
            estimates,
            status,
            requests,
            seq: 0,
            _node: node,
        }))
    }

    /// Everything that arrived since the last call.
    pub fn drain(
        &mut self,
        mut on_estimate: impl FnMut(&EstimateMsg),
        mut on_status: impl FnMut(&SetStatus),
    ) -> Result<(), BusError> {
        while let Some(s) = bus::receive(&self.status)? {
            on_status(&s);
        }
        while let Some(e) = bus::receive(&self.estimates)? {
            on_estimate(&e);
        }
        Ok(())
    }

    /// Was this process asked to terminate (SIGINT, SIGTERM)? iceoryx2 takes both
    /// signals while a node exists, so the monitor asks it and leaves cleanly.
    pub fn terminated(&self) -> bool {
        self._node.wait(std::time::Duration::ZERO).is_err()
    }

    /// Ask the supervisor in charge to stop the run (repeat until its status names this
    /// monitor: a request may be lost while the link between hosts settles).
    pub fn request_stop(&mut self) -> Result<(), BusError> {
        self.seq += 1;
        bus::publish(
            &self.requests,
            Request {
                header: Header {
                    seq: self.seq,
                    publish_ns: monotonic_ns(),
                    ..Default::default()
                },
                command: REQ_STOP,
                requester_pid: std::process::id(),
            },
        )
    }
}
