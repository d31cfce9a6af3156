//! The monitor's ports on a run's bus: the estimates (published off the estimator's
//! loop thread), the supervisor's status, the torque commands and sensor samples (for
//! each stage's latency over a window), all read with queues of their own that
//! overflow safely when the monitor stalls, and the supervisor's request service. No
//! port of the estimator's loop ever connects to it: a publisher connects to a new
//! subscriber inside its next send (which allocates once, in the commander's and the
//! front end's loops), a subscriber only to publishers, and the monitor publishes only
//! to the supervisor.

use crate::bus::{self, BusError};
use crate::msg::{EstimateMsg, Header, Request, SensorSample, SetStatus, TorqueCommand, REQ_STOP};
use crate::timing::monotonic_ns;
use iceoryx2::prelude::*;

/// Node name of every monitor (the supervisor does not take it for a stray stage).
pub const NODE: &str = bus::MONITOR_NODE;

/// A data stream whose headers the monitor times.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Commander → plant.
    Torque,
    /// Front end → estimator.
    Sensor,
}

pub struct Feed {
    estimates: bus::Sub<EstimateMsg>,
    status: bus::Sub<SetStatus>,
    /// None where the service does not reach this host (the commands stay on the
    /// simulation's host of a set over hosts).
    torque: Option<bus::Sub<TorqueCommand>>,
    sensor: Option<bus::Sub<SensorSample>>,
    requests: bus::Pub<Request>,
    prefix: String,
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
        if self.torque.is_none() && bus::service_exists(&self.prefix, bus::SVC_TORQUE) {
            self.torque = Some(bus::subscriber(&self._node, bus::SVC_TORQUE)?);
        }
        if self.sensor.is_none() && bus::service_exists(&self.prefix, bus::SVC_SENSOR) {
            self.sensor = Some(bus::subscriber(&self._node, bus::SVC_SENSOR)?);
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
        while let Some(s) = bus::receive(&self.status)? {
            on_status(&s);
        }
        if let Some(sub) = &self.torque {
            while let Some(m) = bus::receive(sub)? {
                on_stream(Stream::Torque, &m.header);
            }
        }
        if let Some(sub) = &self.sensor {
            while let Some(m) = bus::receive(sub)? {
                on_stream(Stream::Sensor, &m.header);
            }
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
