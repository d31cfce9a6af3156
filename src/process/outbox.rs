//! The estimator's publisher thread. iceoryx2 sets up the connection to a subscriber
//! that appears mid-run inside the publisher's next `send`, and that allocates: an
//! outside client attaching to the estimate stream would allocate in the filter loop.
//! So the loop hands each estimate to a fixed-size single-producer queue and this
//! thread publishes it; the loop itself touches neither the heap nor the connection
//! bookkeeping. Order is kept, nothing is dropped (a full queue makes the loop wait,
//! which the credit windows make rare), and a subscriber that never reads only
//! overflows its own queue (iceoryx2's safe overflow), stalling nobody.

use crate::bus;
use crate::msg::EstimateMsg;
use crate::timing::monotonic_ns;
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
    handle: Option<JoinHandle<Result<(), String>>>,
    quit: Arc<AtomicBool>,
    dead: Arc<AtomicBool>,
}

impl Outbox {
    /// Starts the thread with its own node and publisher on the estimate service and
    /// returns once the publisher exists (estimates sent before would be lost).
    pub fn start(prefix: &str) -> Result<Self, String> {
        // Start-up allocation, once: the queue lives as long as the process.
        let queue: &'static mut Queue<EstimateMsg, DEPTH> = Box::leak(Box::new(Queue::new()));
        let (tx, mut rx) = queue.split();
        let quit = Arc::new(AtomicBool::new(false));
        let dead = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), String>>();
        let prefix = prefix.to_string();
        let (q, d) = (quit.clone(), dead.clone());
        let handle = std::thread::Builder::new()
            .name("estimate-out".into())
            .spawn(move || {
                let mut run = || -> Result<(), String> {
                    let node = bus::node("taiji-estimator-out", &prefix)?;
                    let publisher = bus::publisher::<EstimateMsg>(&node, bus::SVC_ESTIMATE)?;
                    let _ = ready_tx.send(Ok(()));
                    loop {
                        let mut sent = false;
                        while let Some(mut m) = rx.dequeue() {
                            m.header.publish_ns = monotonic_ns();
                            bus::publish(&publisher, m)?;
                            sent = true;
                        }
                        if q.load(Ordering::Acquire) && !rx.ready() {
                            break;
                        }
                        if !sent {
                            std::thread::park_timeout(Duration::from_millis(5));
                        }
                    }
                    drop(publisher);
                    drop(node);
                    Ok(())
                };
                let r = run();
                if let Err(e) = &r {
                    d.store(true, Ordering::Release);
                    let _ = ready_tx.send(Err(e.clone()));
                }
                r
            })
            .map_err(|e| format!("cannot start the estimate publisher thread: {e}"))?;
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(e),
            Err(_) => return Err("the estimate publisher thread died at start".into()),
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
    pub fn send(&mut self, mut m: EstimateMsg) -> Result<(), String> {
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

    fn stop(&mut self) -> String {
        self.quit.store(true, Ordering::Release);
        self.thread.unpark();
        match self.handle.take().map(|h| h.join()) {
            Some(Ok(Err(e))) => format!("estimate publisher: {e}"),
            Some(Err(_)) => "the estimate publisher thread panicked".into(),
            _ => "the estimate publisher stopped".into(),
        }
    }

    /// Publishes what is queued and stops the thread.
    pub fn finish(&mut self) -> Result<(), String> {
        self.quit.store(true, Ordering::Release);
        self.thread.unpark();
        match self.handle.take().map(|h| h.join()) {
            Some(Ok(r)) => r.map_err(|e| format!("estimate publisher: {e}")),
            Some(Err(_)) => Err("the estimate publisher thread panicked".into()),
            None => Ok(()),
        }
    }
}
