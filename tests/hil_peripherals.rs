//! HIL scenarios of the sensor layer: the node (`luxnode run` on the sim board, a real process)
//! with its simulated I2C bus (VEML7700 ambient light sensor, 24C32 EEPROM) and its status LED
//! on a simulated GPIO line whose edges go to a trace file.
//!
//! | scenario | expected |
//! |---|---|
//! | commissioning from scratch | the hooded ALS gives the camera gain straight from the frames, within 0.5 % of the simulated camera's (issue 17: 2 %); the LED blinks the commissioning pattern (500 ms edges), then stays lit while serving |
//! | the run-time check | all luminaires on over Modbus: the ALS agrees with the model (bit 13 clear, bit 12 clear) |
//! | the ALS unplugged | status bit 12 within seconds, a log line naming the sensor and "no acknowledge", the LED's degraded pattern; Modbus answers throughout |
//! | the bus jammed (each transfer hangs 30 s) | bit 12 within the 5 s deadline, "no answer" in the log, Modbus answers within 1 s meanwhile, SIGTERM exits at once |
//! | daylight on the sensor | bit 13 ("more light than modelled") |

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use common::procs::{LUXNODE, Proc, rt, spawn_listening_within};
use luxnode::modbus::regmap::status;
use tokio_modbus::client::{Reader, Writer};

fn sim_board_text() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("boards/sim/board.toml"))
        .unwrap()
}

fn node(board: &Path, flash: &Path, led: &Path, limit: Duration) -> Proc {
    let args: Vec<String> = [
        "run",
        "--board",
        &board.display().to_string(),
        "--flash",
        &flash.display().to_string(),
        "--bind",
        "127.0.0.1:0",
        "--no-controller",
        "--led-trace",
        &led.display().to_string(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    spawn_listening_within(LUXNODE, &args, limit)
}

/// The node's output once it holds `needle`: a log line written just before a status bit is
/// set reaches the test's reader thread a moment later on a loaded machine.
fn output_with(n: &Proc, needle: &str) -> String {
    let t0 = Instant::now();
    loop {
        let out = n.output();
        if out.contains(needle) || t0.elapsed() > Duration::from_secs(10) {
            return out;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Reads the status register (timed).
fn status_reg(n: &Proc) -> (u16, Duration) {
    rt().block_on(async {
        let t0 = Instant::now();
        let mut c = tokio_modbus::client::tcp::connect(n.addr).await.unwrap();
        let v = c.read_input_registers(3, 1).await.unwrap().unwrap();
        (v[0], t0.elapsed())
    })
}

/// Waits until `bit` is `on` in the status register; the longest Modbus answer time seen.
fn wait_bit(n: &Proc, bit: u16, on: bool, limit: Duration) -> Duration {
    let t0 = Instant::now();
    let mut slowest = Duration::ZERO;
    loop {
        let (s, dt) = status_reg(n);
        slowest = slowest.max(dt);
        if (s & bit != 0) == on {
            return slowest;
        }
        assert!(
            t0.elapsed() < limit,
            "status {s:#06x}: bit {bit:#06x} not {on} after {limit:?}\n{}",
            n.output()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// LED edges (ms, lit) from the trace.
fn edges(path: &Path) -> Vec<(u64, bool)> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| {
            let (t, v) = l.split_once(' ')?;
            Some((t.parse().ok()?, v == "1"))
        })
        .collect()
}

/// Intervals between consecutive edges in `[from, to)` ms.
fn intervals(e: &[(u64, bool)], from: u64, to: u64) -> Vec<u64> {
    let w: Vec<u64> = e
        .iter()
        .map(|x| x.0)
        .filter(|&t| t >= from && t < to)
        .collect();
    w.windows(2).map(|p| p[1] - p[0]).collect()
}

#[test]
fn peripherals_on_the_simulated_board() {
    let dir = tempfile::tempdir().unwrap();
    let flash = dir.path().join("flash.bin");
    let board = dir.path().join("board.toml");
    std::fs::write(&board, sim_board_text()).unwrap();

    // 1. commissioning from scratch: the ALS calibrates the camera gain
    let led = dir.path().join("led-1.txt");
    let n = node(&board, &flash, &led, Duration::from_secs(300));
    let out = n.output();
    let line = out
        .lines()
        .find(|l| l.contains("camera gain from the ambient light sensor"))
        .unwrap_or_else(|| panic!("no gain line:\n{out}"));
    let pct: f64 = line
        .rsplit_once('(')
        .and_then(|(_, r)| r.split_once(" %"))
        .and_then(|(p, _)| p.trim().parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    eprintln!("{line}");
    // Issue 17's target is 2 %. The sim board's sensor is hooded (35°, inside the camera's
    // view), so the gain comes straight from the frames: measured +0.03 % with the reading
    // taken as lights on less lights off, +0.09 % before (docs/peripherals.md). A bare sensor's
    // gain comes through the model and its unseen walls (-4.00 % now). Guard: 0.5 %, a quarter
    // of the target.
    assert!(pct.abs() < 0.5, "{line}");
    assert!(
        out.contains("the camera's gain measured directly"),
        "the direct gain was not used:\n{out}"
    );
    // the LED: commissioning edges every 500 ms, then lit while serving
    std::thread::sleep(Duration::from_secs(3));
    let e = edges(&led);
    let serving_at = e.last().map(|x| x.0).unwrap_or(0);
    assert_eq!(e.last().map(|x| x.1), Some(true), "{e:?}");
    let iv = intervals(&e, 0, serving_at);
    assert!(iv.len() >= 4, "{e:?}");
    // the pattern's edges are 500 ms apart; the last may be cut short by the state change
    let ok = iv[..iv.len() - 1]
        .iter()
        .filter(|&&d| (450..=650).contains(&d))
        .count();
    assert!(
        ok * 10 >= (iv.len() - 1) * 8,
        "commissioning pattern: {iv:?}"
    );
    // every luminaire on: the run-time check agrees with the model
    rt().block_on(async {
        let mut c = tokio_modbus::client::tcp::connect(n.addr).await.unwrap();
        c.write_multiple_registers(1000, &[254; 6])
            .await
            .unwrap()
            .unwrap();
    });
    std::thread::sleep(Duration::from_secs(6));
    let (s, _) = status_reg(&n);
    assert_eq!(
        s & (status::PERIPHERAL_FAULT | status::LIGHT_CHECK),
        0,
        "{s:#06x}\n{}",
        n.output()
    );
    let out = output_with(&n, "ambient light check: the sensor reads");
    assert!(
        out.contains("ambient light check: the sensor reads"),
        "{out}"
    );
    assert!(
        e.iter().all(|x| x.0 <= serving_at),
        "no edge while serving healthy"
    );
    assert!(n.terminate().success());

    // 2. the ALS unplugged 2 s after start: status bit, clear log, degraded LED, no hang
    let b2 = dir.path().join("board-unplug.toml");
    std::fs::write(
        &b2,
        format!(
            "{}\n[i2c.sim]\nals_unplugged_after_s = 2\n",
            sim_board_text()
        ),
    )
    .unwrap();
    let led = dir.path().join("led-2.txt");
    let n = node(&b2, &flash, &led, Duration::from_secs(60));
    let slowest = wait_bit(&n, status::PERIPHERAL_FAULT, true, Duration::from_secs(15));
    assert!(slowest < Duration::from_secs(1), "{slowest:?}");
    let needle = "peripheral fault: VEML7700 at 0x10 on sim: I2C: no acknowledge";
    let out = output_with(&n, needle);
    assert!(out.contains(needle), "{out}");
    std::thread::sleep(Duration::from_secs(5));
    let e = edges(&led);
    let iv = intervals(&e, 0, u64::MAX);
    // degraded: 1800 ms lit, 200 ms dark
    assert!(
        iv.windows(2)
            .any(|w| (1700..=1900).contains(&w[0]) && (150..=300).contains(&w[1])),
        "{e:?}"
    );
    assert!(n.terminate().success());

    // 3. the bus jams for 30 s per transfer: the deadline flags it, Modbus keeps answering
    let b3 = dir.path().join("board-stuck.toml");
    std::fs::write(
        &b3,
        format!(
            "{}\n[i2c.sim]\nbus_stuck_after_s = 2\nstuck_timeout_s = 30\n",
            sim_board_text()
        ),
    )
    .unwrap();
    let led = dir.path().join("led-3.txt");
    let n = node(&b3, &flash, &led, Duration::from_secs(60));
    let t0 = Instant::now();
    let slowest = wait_bit(&n, status::PERIPHERAL_FAULT, true, Duration::from_secs(15));
    eprintln!(
        "jammed bus flagged after {:.1} s, slowest Modbus answer {slowest:?}",
        t0.elapsed().as_secs_f64()
    );
    assert!(slowest < Duration::from_secs(1), "{slowest:?}");
    let out = output_with(&n, "no answer for");
    assert!(out.contains("no answer for"), "{out}");
    let t1 = Instant::now();
    assert!(n.terminate().success());
    assert!(
        t1.elapsed() < Duration::from_secs(3),
        "exit took {:?}",
        t1.elapsed()
    );

    // 4. daylight on the sensor: more light than modelled
    let b4 = dir.path().join("board-daylight.toml");
    std::fs::write(
        &b4,
        format!(
            "{}\n[i2c.sim]\ndaylight_lx = 300\ndaylight_after_s = 1\n",
            sim_board_text()
        ),
    )
    .unwrap();
    let led = dir.path().join("led-4.txt");
    let n = node(&b4, &flash, &led, Duration::from_secs(60));
    wait_bit(&n, status::LIGHT_CHECK, true, Duration::from_secs(20));
    let out = output_with(&n, "more light than modelled");
    assert!(out.contains("more light than modelled"), "{out}");
    let (s, _) = status_reg(&n);
    assert_eq!(s & status::PERIPHERAL_FAULT, 0);
    assert!(n.terminate().success());
}
