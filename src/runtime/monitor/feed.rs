//! The monitor's ports on a run's bus: the estimates (published off the estimator's
//! loop thread), the supervisor's status, the torque commands and sensor samples (for
//! each stage's latency over a window), all read with queues of their own that
//! overflow safely when the monitor stalls, and the supervisor's request service. No
//! port of the estimator's loop ever connects to it: a publisher connects to a new
//! subscriber inside its next send (which allocates once, in the commander's and the
//! front end's loops), a subscriber only to publishers, and the monitor publishes only
//! to the supervisor.

use crate::bus::timing::monotonic_ns;
use crate::bus::wiring::{self, BusError};
use crate::sim::msg::{
    EstimateMsg, Header, Request, SensorSample, SetStatus, TorqueCommand, REQ_STOP,
};
use iceoryx2::prelude::*;

/// Node name of every monitor (the supervisor does not take it for a stray stage).
pub const NODE: &str = wiring::MONITOR_NODE;

/// A data stream whose headers the monitor times.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Commander → plant.
    Torque,
    /// Front end → estimator.
    Sensor,
}

pub struct Feed {
    estimates: wiring::Sub<EstimateMsg>,
    status: wiring::Sub<SetStatus>,
    /// None where the service does not reach this host (the commands stay on the
    /// simulation's host of a set over hosts).
    torque: Option<wiring::Sub<TorqueCommand>>,
    sensor: Option<wiring::Sub<SensorSample>>,
    requests: wiring::Pub<Request>,
    prefix: String,
    seq: u64,
    /// Last field: dropped after the ports.
    _node: Node<ipc::Service>,
}

impl Feed {
    /// Attach to the run on `prefix`, if one is there (its supervisor made the status
    /// service); None otherwise, having made nothing on the bus.
    pub fn attach(prefix: &str) -> Result<Option<Feed>, BusError> {
        if !wiring::service_exists(prefix, wiring::SVC_STATUS) {
            return Ok(None);
        }
        let node = wiring::node(NODE, prefix)?;
        let estimates = wiring::subscriber::<EstimateMsg>(&node, wiring::SVC_ESTIMATE)?;
        let status = wiring::subscriber::<SetStatus>(&node, wiring::SVC_STATUS)?;
        let requests = wiring::publisher::<Request>(&node, wiring::SVC_REQUEST)?;
        let mut feed = Feed {
            estimates,
            status,
            torque: None,
            sensor: None,
            requests,
            prefix: prefix.to_string(),
            seq: 0,
            _node: node,
        };
        feed.open_streams()?;
        Ok(Some(feed))
    }

    /// Subscribe to the commands and samples once their services exist (the stages make
    /// them after the supervisor's status appears).
    fn open_streams(&mut self) -> Result<(), BusError> {
        if self.torque.is_none() && wiring::service_exists(&self.prefix, wiring::SVC_TORQUE) {
            self.torque = Some(wiring::subscriber(&self._node, wiring::SVC_TORQUE)?);
        }
        if self.sensor.is_none() && wiring::service_exists(&self.prefix, wiring::SVC_SENSOR) {
            self.sensor = Some(wiring::subscriber(&self._node, wiring::SVC_SENSOR)?);
        }
        Ok(())
    }

    /// Everything that arrived since the last call (the headers of the commands and
    /// samples: only their times are used).
    pub fn drain(
        &mut self,
        mut on_estimate: impl FnMut(&EstimateMsg),
        mut on_status: impl FnMut(&SetStatus),
        mut on_stream: impl FnMut(Stream, &Header),
    ) -> Result<(), BusError> {
        self.open_streams()?;
        while let Some(s) = wiring::receive(&self.status)? {
            on_status(&s);
        }
        if let Some(sub) = &self.torque {
            while let Some(m) = wiring::receive(sub)? {
                on_stream(Stream::Torque, &m.header);
            }
        }
        if let Some(sub) = &self.sensor {
            while let Some(m) = wiring::receive(sub)? {
                on_stream(Stream::Sensor, &m.header);
            }
        }
        while let Some(e) = wiring::receive(&self.estimates)? {
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
        wiring::publish(
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
