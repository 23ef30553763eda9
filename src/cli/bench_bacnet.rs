//! `luxnode bench bacnet-cov-load`: does BACnet slow Modbus? One node serves Modbus TCP and
//! BACnet/IP in this process (the servers `luxnode serve` runs, on a 2-worker runtime); its
//! levels change every 100 ms (luminaire 0 between full and half), so every desk's total moves
//! beyond its COV increment and each subscriber is owed a notification per change. Modbus
//! pollers read the desk floats back to back for a run's duration, with no COV subscriber
//! (A) and with N subscribers (B: in-process UDP sockets, unconfirmed SubscribeCOV to the
//! desks' Analog Inputs, draining their notifications); A and B alternate, R runs each, and
//! the medians of the Modbus request rates are compared. In-process sockets keep the
//! subscribers' own cost (a Python client's interpreter) off the two cores the node shares.

use std::net::SocketAddr;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use luxnode::bacnet::consts::{confirmed, object_type};
use luxnode::bacnet::objects::DeviceInfo;
use luxnode::bacnet::wire::ObjectId;
use luxnode::fieldbus::bacnet::service::ServerConfig;
use luxnode::fieldbus::bacnet::{BacnetCounters, BacnetOptions};
use luxnode::fieldbus::tcp::{TcpCounters, TcpOptions};
use luxnode::node::{SharedNode, lock};
use tokio::net::UdpSocket;

use super::modbus::duration_s;

/// One run's result.
struct Run {
    subscribers: usize,
    requests_per_s: f64,
    notifications_per_s: f64,
}

/// Runs the comparison and prints its table.
pub fn cov_load(
    image: &Path,
    subscribers: usize,
    pollers: usize,
    seconds: f64,
    runs: usize,
) -> Result<()> {
    if !(1..=1000).contains(&subscribers) || !(1..=256).contains(&pollers) {
        bail!("--subscribers 1..=1000, --pollers 1..=256");
    }
    if !(1..=50).contains(&runs) {
        bail!("--runs {runs}: 1..=50");
    }
    let run_for = duration_s("--seconds", seconds)?;
    let node = super::bench::full_on_node(image)?;
    let desks = node.map().desk_count();
    let node: SharedNode = Arc::new(Mutex::new(node));
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let results = rt.block_on(async {
        let (modbus, bacnet, stop) = start_servers(node.clone()).await?;
        let stepping = Arc::new(AtomicBool::new(true));
        tokio::spawn(step_levels(node.clone(), stepping.clone()));
        let mut results = Vec::new();
        for r in 0..2 * runs {
            let n = if r % 2 == 0 { 0 } else { subscribers };
            results.push(one_run(&node, modbus, bacnet, n, desks, pollers, run_for).await?);
        }
        stepping.store(false, Ordering::Relaxed);
        let _ = stop.send(true);
        anyhow::Ok(results)
    })?;
    print_table(&results, pollers, seconds);
    Ok(())
}

/// The Modbus TCP and BACnet/IP servers on free loopback ports.
async fn start_servers(
    node: SharedNode,
) -> Result<(SocketAddr, SocketAddr, tokio::sync::watch::Sender<bool>)> {
    use luxnode::fieldbus::{bacnet, tcp};
    let (stop, stop_rx) = tokio::sync::watch::channel(false);
    let listener = tcp::bind("127.0.0.1:0".parse()?).await?;
    let modbus = listener.local_addr()?;
    tokio::spawn(tcp::serve(
        listener,
        node.clone(),
        TcpOptions::default(),
        Arc::new(TcpCounters::default()),
        stop_rx.clone(),
        None,
    ));
    let socket = bacnet::bind("127.0.0.1:0".parse()?).await?;
    let addr = socket.local_addr()?;
    let options = BacnetOptions {
        bind: addr,
        server: ServerConfig {
            device: DeviceInfo::new(1, "bench"),
            dcc_password: None,
        },
        bbmd: None,
    };
    let counters = lock(&node).health().counters::<BacnetCounters>();
    tokio::spawn(bacnet::serve(
        socket, node, options, counters, stop_rx, None,
    ));
    Ok((modbus, addr, stop))
}

/// Luminaire 0 between full and half every 100 ms while `on`.
async fn step_levels(node: SharedNode, on: Arc<AtomicBool>) {
    let mut full = false;
    while on.load(Ordering::Relaxed) {
        tokio::time::sleep(Duration::from_millis(100)).await;
        full = !full;
        let mut n = lock(&node);
        let mut levels = vec![None; n.levels().len()];
        if let Some(l) = levels.first_mut() {
            *l = Some(if full { 1.0 } else { 0.5 });
        }
        let _ = n.set_levels(&levels);
    }
}

/// One run: `subscribers` subscriptions held while `pollers` poll Modbus for `run_for`.
async fn one_run(
    node: &SharedNode,
    modbus: SocketAddr,
    bacnet: SocketAddr,
    subscribers: usize,
    desks: usize,
    pollers: usize,
    run_for: Duration,
) -> Result<Run> {
    let counters = lock(node).health().counters::<BacnetCounters>();
    let mut subs = Vec::new();
    for k in 0..subscribers {
        let ai = ObjectId::new(object_type::ANALOG_INPUT, (k % desks.max(1)) as u32);
        subs.push(Subscriber::subscribe(bacnet, ai).await?);
    }
    // the initial notifications are not the run's
    tokio::time::sleep(Duration::from_millis(200)).await;
    let sent0 = counters.notifications.load(Ordering::Relaxed);
    let t0 = Instant::now();
    let requests = poll_modbus(modbus, desks, pollers, run_for).await;
    let elapsed = t0.elapsed().as_secs_f64();
    let sent = counters.notifications.load(Ordering::Relaxed) - sent0;
    for s in subs {
        s.cancel(bacnet).await;
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    Ok(Run {
        subscribers,
        requests_per_s: requests as f64 / elapsed,
        notifications_per_s: sent as f64 / elapsed,
    })
}

/// Requests `pollers` Modbus clients complete back to back in `run_for`.
async fn poll_modbus(addr: SocketAddr, desks: usize, pollers: usize, run_for: Duration) -> u64 {
    use tokio_modbus::client::Reader;
    let done = Arc::new(AtomicU64::new(0));
    let deadline = tokio::time::Instant::now() + run_for;
    let n = u16::try_from(2 * desks).unwrap_or(u16::MAX);
    let mut tasks = Vec::new();
    for _ in 0..pollers {
        let done = done.clone();
        tasks.push(tokio::spawn(async move {
            let Ok(mut c) = tokio_modbus::client::tcp::connect(addr).await else {
                return;
            };
            while tokio::time::Instant::now() < deadline {
                if let Ok(Ok(_)) = c.read_input_registers(100, n).await {
                    done.fetch_add(1, Ordering::Relaxed);
                }
            }
        }));
    }
    for t in tasks {
        let _ = t.await;
    }
    done.load(Ordering::Relaxed)
}

/// A COV subscriber: its socket, and the task draining its notifications.
struct Subscriber {
    socket: Arc<UdpSocket>,
    object: ObjectId,
    drain: tokio::task::JoinHandle<()>,
}

/// A SubscribeCOV datagram (process id 1): unconfirmed with a lifetime, or a cancellation.
fn subscribe_cov(object: ObjectId, lifetime_s: Option<u64>) -> Vec<u8> {
    luxnode::fieldbus::bacnet::fuzz::request(confirmed::SUBSCRIBE_COV, |w| {
        let _ = w.context_unsigned(0, 1);
        let _ = w.context_object_id(1, object);
        if let Some(l) = lifetime_s {
            let _ = w.context_bool(2, false);
            let _ = w.context_unsigned(3, l);
        }
    })
}

impl Subscriber {
    async fn subscribe(bacnet: SocketAddr, object: ObjectId) -> Result<Self> {
        let socket = Arc::new(UdpSocket::bind("127.0.0.1:0").await?);
        socket
            .send_to(&subscribe_cov(object, Some(600)), bacnet)
            .await?;
        let s = socket.clone();
        let drain = tokio::spawn(async move {
            let mut buf = [0u8; 1500];
            while s.recv_from(&mut buf).await.is_ok() {}
        });
        Ok(Self {
            socket,
            object,
            drain,
        })
    }

    async fn cancel(self, bacnet: SocketAddr) {
        let _ = self
            .socket
            .send_to(&subscribe_cov(self.object, None), bacnet)
            .await;
        tokio::time::sleep(Duration::from_millis(5)).await;
        self.drain.abort();
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

fn print_table(results: &[Run], pollers: usize, seconds: f64) {
    println!(
        "| run | COV subscribers | Modbus requests/s ({pollers} pollers, {seconds:.0} s) | COV notifications/s |"
    );
    println!("|---:|---:|---:|---:|");
    for (k, r) in results.iter().enumerate() {
        println!(
            "| {} | {} | {:.0} | {:.0} |",
            k + 1,
            r.subscribers,
            r.requests_per_s,
            r.notifications_per_s
        );
    }
    let rate = |with: bool| {
        median(
            results
                .iter()
                .filter(|r| (r.subscribers > 0) == with)
                .map(|r| r.requests_per_s)
                .collect(),
        )
    };
    let (without, with) = (rate(false), rate(true));
    println!(
        "\nmedian Modbus requests/s: {without:.0} without subscribers, {with:.0} with; \
         {:+.1} % (target: within 10 %)",
        100.0 * (with / without - 1.0)
    );
}
