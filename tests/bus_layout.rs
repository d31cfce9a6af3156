//! A build (or an outside client) with another message layout cannot share a bus with
//! this one: iceoryx2 compares the payload type names, which carry the layout version,
//! and our error says what happened instead of iceoryx2's bare `IncompatibleTypes`.

use iceoryx2::prelude::*;
use taiji::bus::wiring;
use taiji::sim::msg::EstimateMsg;

/// What an older build's estimate looked like on the bus: same name, other layout.
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("taiji::v0::EstimateMsg")]
#[repr(C)]
struct OldEstimate {
    tick: u64,
    beta: [[f64; 3]; 2],
}

#[test]
fn a_peer_with_another_layout_is_refused_with_a_clear_message() {
    let prefix = format!("tjlayout{}_", std::process::id());
    let node = wiring::node("old-build", &prefix).unwrap();
    // The old build's estimator created the service first.
    let sn: ServiceName = wiring::SVC_ESTIMATE.try_into().unwrap();
    let _old = node
        .service_builder(&sn)
        .publish_subscribe::<OldEstimate>()
        .open_or_create()
        .unwrap();
    let ours = wiring::node("new-build", &prefix).unwrap();
    let Err(e) = wiring::subscriber::<EstimateMsg>(&ours, wiring::SVC_ESTIMATE) else {
        panic!("a service of another layout must be refused");
    };
    let e = e.to_string();
    assert!(e.contains("message layout version 1"), "{e}");
    assert!(e.contains("another build"), "{e}");
    drop(ours);
    drop(_old);
    drop(node);
    let _ = wiring::release(&prefix);
}
