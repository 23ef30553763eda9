//! COV subscriptions (SubscribeCOV) and the notifications they are owed.
//!
//! A subscription is (subscriber address, process id, object), confirmed or not, with a
//! lifetime (0: until cancelled or the node restarts). [`CovTable::due`] compares each
//! subscribed object's Present_Value and Status_Flags with what the subscriber was last told:
//! a change of the value by COV_Increment or more, or of any flag, is due. The server calls it
//! every [`POLL`], so a notification leaves within that of the change.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use super::wire::{NetAddress, ObjectId};

/// Most subscriptions held at once.
pub const MAX_SUBSCRIPTIONS: usize = 256;
/// Most subscriptions of one IP address (one client cannot take the whole table).
pub const MAX_PER_ADDRESS: usize = 128;
/// How often the server looks for changes.
pub const POLL: Duration = Duration::from_millis(100);
/// Longest lifetime a subscriber may ask for, s (a day; longer is clamped).
pub const MAX_LIFETIME_S: u64 = 86_400;

/// Where a reply or notification goes: the UDP address, and the routed source behind it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Peer {
    /// BACnet/IP address.
    pub addr: SocketAddr,
    /// SNET/SADR of a request that came through a router.
    pub route: Option<NetAddress>,
}

/// What the subscriber was last told.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Told {
    /// Present_Value.
    pub value: f64,
    /// Status_Flags.
    pub flags: [bool; 4],
}

/// One subscription.
#[derive(Debug, Clone, PartialEq)]
pub struct Subscription {
    /// Subscriber.
    pub peer: Peer,
    /// Subscriber's process identifier.
    pub process_id: u32,
    /// Monitored object.
    pub object: ObjectId,
    /// Confirmed notifications.
    pub confirmed: bool,
    /// When it ends (`None`: indefinite).
    pub expires: Option<Instant>,
    /// The last notification's content (`None`: the initial one is owed).
    pub told: Option<Told>,
}

impl Subscription {
    /// Seconds left (0 for an indefinite one).
    pub fn remaining_s(&self, now: Instant) -> u64 {
        self.expires
            .map_or(0, |e| e.saturating_duration_since(now).as_secs().max(1))
    }

    fn same(&self, peer: &Peer, process_id: u32, object: ObjectId) -> bool {
        self.peer.addr == peer.addr && self.process_id == process_id && self.object == object
    }
}

/// The table is full.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "no room for another COV subscription ({MAX_SUBSCRIPTIONS} in all, {MAX_PER_ADDRESS} per address)"
)]
pub struct Full;

/// The subscriptions.
#[derive(Debug, Default)]
pub struct CovTable {
    subs: Vec<Subscription>,
}

impl CovTable {
    /// Subscriptions held.
    pub fn len(&self) -> usize {
        self.subs.len()
    }

    /// True when none is held.
    pub fn is_empty(&self) -> bool {
        self.subs.is_empty()
    }

    /// Adds or renews a subscription (a renewal owes a fresh initial notification).
    pub fn subscribe(
        &mut self,
        peer: Peer,
        process_id: u32,
        object: ObjectId,
        confirmed: bool,
        lifetime_s: u64,
        now: Instant,
    ) -> Result<(), Full> {
        let expires =
            (lifetime_s > 0).then(|| now + Duration::from_secs(lifetime_s.min(MAX_LIFETIME_S)));
        let sub = Subscription {
            peer,
            process_id,
            object,
            confirmed,
            expires,
            told: None,
        };
        if let Some(s) = self
            .subs
            .iter_mut()
            .find(|s| s.same(&peer, process_id, object))
        {
            *s = sub;
            return Ok(());
        }
        let same_ip = self
            .subs
            .iter()
            .filter(|s| s.peer.addr.ip() == peer.addr.ip())
            .count();
        if self.subs.len() >= MAX_SUBSCRIPTIONS || same_ip >= MAX_PER_ADDRESS {
            return Err(Full);
        }
        self.subs.push(sub);
        Ok(())
    }

    /// Cancels a subscription (none: nothing to do).
    pub fn cancel(&mut self, peer: &Peer, process_id: u32, object: ObjectId) {
        self.subs.retain(|s| !s.same(peer, process_id, object));
    }

    /// The subscriptions owed a notification now, marked as told: expired ones are dropped
    /// first. `current` gives an object's value, flags and COV_Increment.
    pub fn due(
        &mut self,
        now: Instant,
        mut current: impl FnMut(ObjectId) -> Option<(Told, f64)>,
    ) -> Vec<Subscription> {
        self.subs.retain(|s| s.expires.is_none_or(|e| e > now));
        let mut out = Vec::new();
        for s in &mut self.subs {
            let Some((now_told, increment)) = current(s.object) else {
                continue;
            };
            let owed = match &s.told {
                None => true,
                Some(t) => changed(t, &now_told, increment),
            };
            if owed {
                s.told = Some(now_told);
                out.push(s.clone());
            }
        }
        out
    }
}

/// True when `b` differs from `a` enough to notify: flags, availability, or the value by
/// `increment` or more.
fn changed(a: &Told, b: &Told, increment: f64) -> bool {
    if a.flags != b.flags || a.value.is_finite() != b.value.is_finite() {
        return true;
    }
    a.value.is_finite() && (b.value - a.value).abs() >= increment.max(0.0) && a.value != b.value
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peer(port: u16) -> Peer {
        Peer {
            addr: SocketAddr::from(([127, 0, 0, 1], port)),
            route: None,
        }
    }

    #[test]
    fn notifications_are_due_first_then_on_changes_beyond_the_increment() {
        let mut t = CovTable::default();
        let now = Instant::now();
        let o = ObjectId::new(0, 3);
        t.subscribe(peer(1), 7, o, false, 60, now).unwrap();
        let mut value = 100.0;
        let flags = [false; 4];
        let due = |t: &mut CovTable, v: f64, f: [bool; 4]| {
            t.due(now, |_| Some((Told { value: v, flags: f }, 5.0)))
                .len()
        };
        assert_eq!(due(&mut t, value, flags), 1, "initial");
        assert_eq!(due(&mut t, value, flags), 0);
        value += 4.9;
        assert_eq!(due(&mut t, value, flags), 0, "below the increment");
        value += 0.2;
        assert_eq!(due(&mut t, value, flags), 1, "5.1 from the last told");
        assert_eq!(due(&mut t, value, [false, true, false, false]), 1, "fault");
        assert_eq!(due(&mut t, f64::NAN, [false, true, false, false]), 1, "NaN");
        assert_eq!(due(&mut t, f64::NAN, [false, true, false, false]), 0);
    }

    #[test]
    fn lifetimes_renewals_cancellation_and_the_cap() {
        let mut t = CovTable::default();
        let now = Instant::now();
        let o = ObjectId::new(0, 1);
        t.subscribe(peer(1), 1, o, true, 2, now).unwrap();
        t.subscribe(peer(1), 1, o, true, 2, now).unwrap();
        assert_eq!(t.len(), 1, "a renewal is not a second subscription");
        let later = now + Duration::from_secs(3);
        assert!(t.due(later, |_| None).is_empty());
        assert_eq!(t.len(), 0, "expired");
        for k in 0..MAX_PER_ADDRESS as u32 {
            t.subscribe(peer(2), k, o, false, 0, now).unwrap();
        }
        assert_eq!(
            t.subscribe(peer(2), 999, o, false, 0, now),
            Err(Full),
            "one address's share"
        );
        let other = |port| Peer {
            addr: SocketAddr::from(([127, 0, 0, 2], port)),
            route: None,
        };
        for k in 0..(MAX_SUBSCRIPTIONS - MAX_PER_ADDRESS) as u32 {
            t.subscribe(other(1), k, o, false, 0, now).unwrap();
        }
        let third = Peer {
            addr: SocketAddr::from(([127, 0, 0, 3], 1)),
            route: None,
        };
        assert_eq!(t.subscribe(third, 0, o, false, 0, now), Err(Full), "all");
        t.cancel(&peer(2), 5, o);
        assert_eq!(t.len(), MAX_SUBSCRIPTIONS - 1);
        t.subscribe(third, 0, o, false, 0, now).unwrap();
    }
}
