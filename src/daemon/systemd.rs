//! systemd notifications (`sd_notify`): READY, WATCHDOG, STOPPING, over the datagram socket
//! named by `$NOTIFY_SOCKET`. Without it (not started by systemd) every call does nothing.
//! The unit file is `deploy/luxnode.service` (Type=notify, WatchdogSec).

use std::time::Duration;

/// Sends one notification; errors are logged, never fatal.
pub fn notify(state: &str) {
    if let Some(path) = std::env::var_os("NOTIFY_SOCKET") {
        notify_to(&path, state);
    }
}

/// Sends `state` to the notification socket `path` (`@name`: abstract namespace).
pub fn notify_to(path: &std::ffi::OsStr, state: &str) {
    #[cfg(unix)]
    {
        use std::os::unix::net::UnixDatagram;
        let Ok(sock) = UnixDatagram::unbound() else {
            return;
        };
        let bytes = path.as_encoded_bytes();
        let sent = if let Some(name) = bytes.strip_prefix(b"@") {
            // abstract socket namespace (Linux)
            #[cfg(target_os = "linux")]
            {
                use std::os::linux::net::SocketAddrExt;
                std::os::unix::net::SocketAddr::from_abstract_name(name)
                    .and_then(|a| sock.send_to_addr(state.as_bytes(), &a))
            }
            #[cfg(not(target_os = "linux"))]
            {
                let _ = name;
                Err(std::io::Error::other("abstract sockets need Linux"))
            }
        } else {
            sock.send_to(state.as_bytes(), path)
        };
        if let Err(e) = sent {
            tracing::warn!("sd_notify {state}: {e}");
        }
    }
}

/// The watchdog period systemd asked for (`$WATCHDOG_USEC`), if it is for this process.
pub fn watchdog_period() -> Option<Duration> {
    watchdog_period_from(
        std::env::var("WATCHDOG_USEC").ok().as_deref(),
        std::env::var("WATCHDOG_PID").ok().as_deref(),
        std::process::id(),
    )
}

/// The watchdog period from the values of `WATCHDOG_USEC` and `WATCHDOG_PID`.
pub fn watchdog_period_from(usec: Option<&str>, pid: Option<&str>, me: u32) -> Option<Duration> {
    let usec: u64 = usec?.parse().ok()?;
    if let Some(pid) = pid
        && pid.parse::<u32>().ok() != Some(me)
    {
        return None;
    }
    (usec > 0).then(|| Duration::from_micros(usec))
}

/// Why the watchdog is not petted now (`None`: every part is alive and the node answers).
pub async fn unhealthy(
    health: &crate::node::health::Health,
    node: &crate::node::SharedNode,
) -> Option<String> {
    let late = health.late();
    if !late.is_empty() {
        let parts: Vec<String> = late
            .iter()
            .map(|(name, silent)| format!("{name} silent for {:.1} s", silent.as_secs_f64()))
            .collect();
        return Some(parts.join(", "));
    }
    // the node's lock is taken for microseconds per request: a second means a hang
    let n = node.clone();
    let locked = tokio::time::timeout(
        Duration::from_secs(1),
        tokio::task::spawn_blocking(move || {
            drop(crate::node::lock(&n));
        }),
    )
    .await;
    match locked {
        Ok(Ok(())) => None,
        _ => Some("the node's state is locked for more than 1 s".into()),
    }
}

/// Pets the watchdog at half its period while every part is alive ([`unhealthy`]), forever
/// (abort the task to stop). A hung or dead part stops the petting: systemd restarts the node.
pub async fn watchdog_loop(
    health: std::sync::Arc<crate::node::health::Health>,
    node: crate::node::SharedNode,
) {
    let Some(period) = watchdog_period() else {
        return;
    };
    let mut tick = tokio::time::interval(period / 2);
    let mut was_ok = true;
    loop {
        tick.tick().await;
        match unhealthy(&health, &node).await {
            None => {
                if !was_ok {
                    tracing::info!("watchdog: every part alive again; petting");
                }
                was_ok = true;
                notify("WATCHDOG=1");
            }
            Some(why) => {
                if was_ok {
                    tracing::error!("watchdog: not petted: {why}");
                }
                was_ok = false;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    #[test]
    fn notifications_reach_the_socket() {
        use std::os::unix::net::UnixDatagram;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notify");
        let server = UnixDatagram::bind(&path).unwrap();
        super::notify_to(path.as_os_str(), "READY=1");
        let mut buf = [0u8; 64];
        let n = server.recv(&mut buf).unwrap();
        assert_eq!(&buf[..n], b"READY=1");
    }

    #[test]
    fn the_watchdog_is_not_petted_while_a_part_is_late() {
        use crate::node::health::Health;
        use crate::node::{Node, NodeModel, NodeOptions};
        use std::sync::{Arc, Mutex};
        let health = Arc::new(Health::default());
        let model = NodeModel {
            response_lx: vec![1.0],
            sensor_ids: vec![1],
            luminaire_ids: vec![1],
            sensor_flags: vec![0],
            model_rel_uncertainty: vec![f64::NAN],
            uncertainty_parts_lx: Vec::new(),
            occluder_groups: Vec::new(),
            generation: 1,
            luminaire_power: vec![crate::control::rating::RatedPower::assumed(1000.0)],
            point_names: Vec::new(),
        };
        let node = Arc::new(Mutex::new(
            Node::new(
                model,
                NodeOptions {
                    health: Some(health.clone()),
                    ..NodeOptions::default()
                },
            )
            .unwrap(),
        ));
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            let rtu = health.register("modbus rtu", Duration::from_millis(50));
            assert_eq!(super::unhealthy(&health, &node).await, None);
            tokio::time::sleep(Duration::from_millis(120)).await;
            let why = super::unhealthy(&health, &node).await.expect("late");
            assert!(why.contains("modbus rtu silent"), "{why}");
            rtu.beat();
            assert_eq!(super::unhealthy(&health, &node).await, None);
            // a node whose state stays locked: not petted either
            let held = node.clone();
            let guard = std::thread::spawn(move || {
                let _g = held.lock().unwrap();
                std::thread::sleep(Duration::from_millis(1500));
            });
            tokio::time::sleep(Duration::from_millis(100)).await;
            rtu.beat();
            let why = super::unhealthy(&health, &node).await.expect("locked");
            assert!(why.contains("locked"), "{why}");
            guard.join().unwrap();
        });
    }

    #[test]
    fn watchdog_period_is_for_this_process_only() {
        use super::watchdog_period_from as w;
        assert_eq!(w(Some("2000000"), None, 7), Some(Duration::from_secs(2)));
        assert_eq!(
            w(Some("2000000"), Some("7"), 7),
            Some(Duration::from_secs(2))
        );
        assert_eq!(w(Some("2000000"), Some("8"), 7), None);
        assert_eq!(w(Some("0"), None, 7), None);
        assert_eq!(w(Some("x"), None, 7), None);
        assert_eq!(w(None, None, 7), None);
    }
}
