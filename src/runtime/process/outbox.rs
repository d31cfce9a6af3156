//! The estimator's publisher thread. iceoryx2 sets up the connection to a subscriber
//! that appears mid-run inside the publisher's next `send`, and that allocates: an
//! outside client attaching to the estimate stream would allocate in the filter loop.
//! So the loop hands each estimate to a fixed-size single-producer queue and this
//! thread publishes it; the loop itself touches neither the heap nor the connection
//! bookkeeping. Order is kept, nothing is dropped (a full queue makes the loop wait,
//! which the credit windows make rare), and a subscriber that never reads only
//! overflows its own queue (iceoryx2's safe overflow), stalling nobody.

use super::ProcessError;
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring::{self, BusError};
use crate::sim::msg::EstimateMsg;
use heapless::spsc::{Producer, Queue};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::{JoinHandle, Thread};
use std::time::Duration;

/// Queue depth [messages] (capacity one less): more than the flow-control window.
const DEPTH: usize = 1024;

pub struct Outbox {
    tx: Producer<'static, EstimateMsg, DEPTH>,
    thread: Thread,
    handle: Option<JoinHandle<Result<(), BusError>>>,
    quit: Arc<AtomicBool>,
    dead: Arc<AtomicBool>,
}

impl Outbox {
    /// Starts the thread with its own node and publisher on the estimate service and
    /// returns once the publisher exists (estimates sent before would be lost).
    pub fn start(prefix: &str) -> Result<Self, ProcessError> {
        // Start-up allocation, once: the queue lives as long as the process.
        let queue: &'static mut Queue<EstimateMsg, DEPTH> = Box::leak(Box::new(Queue::new()));
        let (tx, mut rx) = queue.split();
        let quit = Arc::new(AtomicBool::new(false));
        let dead = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), BusError>>();
        let prefix = prefix.to_string();
        let (q, d) = (quit.clone(), dead.clone());
        let handle = std::thread::Builder::new()
            .name("estimate-out".into())
            .spawn(move || {
                let ports = wiring::node("taiji-estimator-out", &prefix).and_then(|node| {
                    let publisher = wiring::publisher::<EstimateMsg>(&node, wiring::SVC_ESTIMATE)?;
                    Ok((node, publisher))
                });
                let (node, publisher) = match ports {
                    Ok(ports) => ports,
                    Err(e) => {
                        // Reported by `start`, which is waiting for it.
                        d.store(true, Ordering::Release);
                        let _ = ready_tx.send(Err(e));
                        return Ok(());
                    }
                };
                let _ = ready_tx.send(Ok(()));
                let r = (|| loop {
                    let mut sent = false;
                    while let Some(mut m) = rx.dequeue() {
                        m.header.publish_ns = monotonic_ns();
                        wiring::publish(&publisher, m)?;
                        sent = true;
                    }
                    if q.load(Ordering::Acquire) && !rx.ready() {
                        return Ok(());
                    }
                    if !sent {
                        std::thread::park_timeout(Duration::from_millis(5));
                    }
                })();
                if r.is_err() {
                    d.store(true, Ordering::Release);
                }
                drop(publisher);
                drop(node);
                r
            })
            .map_err(ProcessError::OutboxSpawn)?;
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(e.into()),
            Err(_) => return Err(ProcessError::OutboxDiedAtStart),
        }
        Ok(Outbox {
            tx,
            thread: handle.thread().clone(),
            handle: Some(handle),
            quit,
            dead,
        })
    }

    /// Hands one estimate to the publisher (no allocation; waits while the queue is full).
    pub fn send(&mut self, mut m: EstimateMsg) -> Result<(), ProcessError> {
        loop {
            match self.tx.enqueue(m) {
                Ok(()) => {
                    self.thread.unpark();
                    return Ok(());
                }
                Err(back) => {
                    if self.dead.load(Ordering::Acquire) {
                        return Err(self.stop());
                    }
                    m = back;
                    self.thread.unpark();
                    std::thread::yield_now();
                }
            }
        }
    }

    fn stop(&mut self) -> ProcessError {
        self.quit.store(true, Ordering::Release);
        self.thread.unpark();
        match self.handle.take().map(|h| h.join()) {
            Some(Ok(Err(e))) => ProcessError::Outbox(e),
            Some(Err(_)) => ProcessError::OutboxPanicked,
            _ => ProcessError::OutboxStopped,
        }
    }

    /// Publishes what is queued and stops the thread.
    pub fn finish(&mut self) -> Result<(), ProcessError> {
        self.quit.store(true, Ordering::Release);
        self.thread.unpark();
        match self.handle.take().map(|h| h.join()) {
            Some(Ok(r)) => r.map_err(ProcessError::Outbox),
            Some(Err(_)) => Err(ProcessError::OutboxPanicked),
            None => Ok(()),
        }
    }
}
