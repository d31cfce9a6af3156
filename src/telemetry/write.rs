//! `telemetry.h5` writer (pure-Rust HDF5): one dataset per channel, `units` and
//! `description` attributes on each, the scenario and software version on the root.

use super::layout::{self as l, Channel};
use super::{Meta, Telemetry};
use hdf5_pure::{AttrValue, DatasetBuilder, FileBuilder, GroupBuilder};
use std::borrow::Cow;
use std::collections::BTreeMap;

fn text(s: &str) -> AttrValue {
    AttrValue::VarLenString(s.to_string())
}

fn annotate(d: &mut DatasetBuilder, c: &Channel) {
    d.set_attr("units", text(c.units));
    d.set_attr("description", text(c.description));
}

/// Datasets grouped by their parent group ("" for the root).
#[derive(Default)]
struct Tree<'a> {
    groups: BTreeMap<&'static str, Vec<Item<'a>>>,
}

/// A channel's values: borrowed from the recording, or derived for the file.
enum Data<'a> {
    F64(Cow<'a, [f64]>),
    U64(Cow<'a, [u64]>),
    U8(Cow<'a, [u8]>),
}

struct Item<'a> {
    name: &'static str,
    channel: &'static Channel,
    shape: Vec<u64>,
    data: Data<'a>,
}

impl<'a> Tree<'a> {
    fn add(&mut self, path: &'static str, shape: &[usize], data: Data<'a>) {
        let channel = l::channel(path);
        let (group, name) = path.rsplit_once('/').unwrap_or(("", path));
        self.groups.entry(group).or_default().push(Item {
            name,
            channel,
            shape: shape.iter().map(|&n| n as u64).collect(),
            data,
        });
    }
}

fn put(d: &mut DatasetBuilder, item: &Item) {
    match &item.data {
        Data::F64(v) => d.with_f64_data(v),
        Data::U64(v) => d.with_u64_data(v),
        Data::U8(v) => d.with_u8_data(v),
    };
    d.with_shape(&item.shape);
    annotate(d, item.channel);
}

pub(super) fn write(t: &Telemetry, path: &std::path::Path, meta: &Meta) -> Result<(), String> {
    let n = t.truth_tick.len();
    if t.sensor_tick.len() != n || t.truth_tick != t.sensor_tick {
        return Err(format!(
            "telemetry incomplete: {} truth rows and {} sensor rows of different ticks",
            n,
            t.sensor_tick.len()
        ));
    }
    let ni = t.n_is;
    let fs = t.fs;
    let mut tree = Tree::default();
    let time: Vec<f64> = t.truth_tick.iter().map(|&k| (k + 1) as f64 / fs).collect();
    tree.add(l::TIME, &[n], Data::F64(Cow::Owned(time)));
    tree.add(l::TICK, &[n], Data::U64(Cow::Borrowed(&t.truth_tick)));
    tree.add(
        l::TORQUE_CMD,
        &[n, 3],
        Data::F64(Cow::Borrowed(&t.torque_cmd)),
    );
    tree.add(l::TORQUE, &[n, 3], Data::F64(Cow::Borrowed(&t.torque)));
    tree.add(l::ATTITUDE, &[n, 4], Data::F64(Cow::Borrowed(&t.attitude)));
    tree.add(l::OMEGA, &[n, 3], Data::F64(Cow::Borrowed(&t.omega)));
    tree.add(
        l::OMEGA_DOT,
        &[n, 3],
        Data::F64(Cow::Borrowed(&t.omega_dot)),
    );
    tree.add(l::TM_ACC, &[n, ni, 3], Data::F64(Cow::Borrowed(&t.tm_acc)));
    tree.add(l::SRP_ACC, &[n, 3], Data::F64(Cow::Borrowed(&t.srp_acc)));
    tree.add(l::STAR_Q, &[n, 4], Data::F64(Cow::Borrowed(&t.star_q)));
    tree.add(l::STAR_VALID, &[n], Data::U8(Cow::Borrowed(&t.star_valid)));
    for i in 0..ni {
        tree.add(
            l::IS_VOLTAGE[i],
            &[n, 3, 2],
            Data::F64(Cow::Borrowed(&t.is_volts[i])),
        );
        tree.add(
            l::IS_FLAGS[i],
            &[n],
            Data::U8(Cow::Borrowed(&t.is_flags[i])),
        );
    }
    let e = &t.estimates;
    let m = e.len();
    let per_is = |f: &dyn Fn(&crate::msg::EstimateMsg, usize) -> [f64; 3]| -> Data {
        Data::F64(
            e.iter()
                .flat_map(|r| (0..ni).flat_map(move |i| f(r, i)))
                .collect(),
        )
    };
    tree.add(
        l::EST_TIME,
        &[m],
        Data::F64(e.iter().map(|r| (r.header.tick + 1) as f64 / fs).collect()),
    );
    tree.add(
        l::EST_TICK,
        &[m],
        Data::U64(e.iter().map(|r| r.solved_tick).collect()),
    );
    tree.add(l::EST_BETA, &[m, ni, 3], per_is(&|r, i| r.beta[i]));
    tree.add(
        l::EST_BETA_SIGMA,
        &[m, ni, 3],
        per_is(&|r, i| r.beta_sigma[i]),
    );
    tree.add(l::EST_K, &[m, ni, 3], per_is(&|r, i| r.k[i]));
    tree.add(l::EST_K_SIGMA, &[m, ni, 3], per_is(&|r, i| r.k_sigma[i]));
    tree.add(l::EST_R, &[m, ni, 3], per_is(&|r, i| r.r_b[i]));
    tree.add(l::EST_R_SIGMA, &[m, ni, 3], per_is(&|r, i| r.r_sigma[i]));
    tree.add(
        l::EST_N_USED,
        &[m],
        Data::U64(e.iter().map(|r| r.n_used).collect()),
    );
    tree.add(
        l::EST_N_REJECTED,
        &[m],
        Data::U64(e.iter().map(|r| r.n_rejected).collect()),
    );
    tree.add(
        l::EST_FINAL,
        &[m],
        Data::U8(
            e.iter()
                .map(|r| u8::from(r.flags & crate::msg::EST_FINAL != 0))
                .collect(),
        ),
    );
    tree.add(
        l::EST_STATUS,
        &[m],
        Data::U64(e.iter().map(|r| r.status).collect()),
    );
    tree.add(
        l::EST_REJECTED_BY_CAUSE,
        &[m, crate::msg::N_CAUSES],
        Data::U64(e.iter().flat_map(|r| r.rejected_by_cause).collect()),
    );
    tree.add(
        l::EST_CHI2,
        &[m, crate::msg::N_GROUPS],
        Data::F64(e.iter().flat_map(|r| r.chi2_per_dof).collect()),
    );
    let f = &t.faults;
    if !f.is_empty() {
        let nf = f.len();
        let u = |g: &dyn Fn(&crate::faults::FaultRecord) -> u64| -> Data {
            Data::U64(f.iter().map(g).collect())
        };
        let x = |g: &dyn Fn(&crate::faults::FaultRecord) -> f64| -> Data {
            Data::F64(f.iter().map(g).collect())
        };
        tree.add(l::FAULT_TICK, &[nf], u(&|r| r.tick));
        tree.add(l::FAULT_KIND, &[nf], u(&|r| r.kind as u64));
        tree.add(l::FAULT_FIELD, &[nf], u(&|r| r.field as u64));
        tree.add(l::FAULT_BIT, &[nf], u(&|r| r.bit as u64));
        tree.add(l::FAULT_SAMPLES, &[nf], u(&|r| r.samples as u64));
        tree.add(l::FAULT_BEFORE, &[nf], x(&|r| r.before));
        tree.add(l::FAULT_AFTER, &[nf], x(&|r| r.after));
        tree.add(l::FAULT_SIGMAS, &[nf], x(&|r| r.sigmas));
        let mut det = t.faults_detected.clone();
        det.resize(nf, 0);
        tree.add(l::FAULT_DETECTED, &[nf], Data::U64(Cow::Owned(det)));
    }

    let mut b = FileBuilder::new();
    b.set_attr("format", text(l::FORMAT));
    b.set_attr("format_version", AttrValue::U64(l::FORMAT_VERSION));
    b.set_attr(
        "software",
        text(concat!(
            env!("CARGO_PKG_NAME"),
            " ",
            env!("CARGO_PKG_VERSION")
        )),
    );
    b.set_attr("scenario", text(&meta.scenario_toml));
    b.set_attr("scenario_name", text(&meta.scenario_name));
    b.set_attr("seed", AttrValue::U64(meta.seed));
    b.set_attr("method", text(&meta.method));
    b.set_attr("mode", text(&meta.mode));
    b.set_attr("sample_rate_hz", AttrValue::F64(meta.sample_rate_hz));
    b.set_attr("duration_s", AttrValue::F64(meta.duration_s));
    b.set_attr("n_inertial_sensors", AttrValue::U64(meta.n_is as u64));
    for (group, items) in &tree.groups {
        if group.is_empty() {
            for item in items {
                put(b.create_dataset(item.name), item);
            }
            continue;
        }
        let mut g: GroupBuilder = b.create_group(group);
        for item in items {
            put(g.create_dataset(item.name), item);
        }
        b.add_group(g.finish());
    }
    let tmp = path.with_extension("h5.tmp");
    b.write(&tmp)
        .map_err(|e| format!("cannot write {}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("cannot write {}: {e}", path.display()))
}
