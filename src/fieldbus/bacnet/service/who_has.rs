//! Who-Has → I-Have (DM-DOB-B): the node looks the object up by identifier or by Object_Name
//! among the objects it has now and, when it has it and its instance is inside the request's
//! limits, answers with an I-Have unicast to the requester (through its router when it came
//! through one), as it answers Who-Is. A Who-Has that does not parse, or for an object the
//! node does not have, is not answered (an unconfirmed request has nobody to refuse to).

use super::{Outgoing, Server, datagram, view};
use crate::bacnet::consts::{object_type as ot, unconfirmed};
use crate::bacnet::cov::Peer;
use crate::bacnet::who_has::{IHave, Wanted, WhoHas};
use crate::bacnet::wire::ObjectId;
use crate::node::Node;

impl Server {
    /// The I-Have answering Who-Has service data `data` from `peer`, if the node has the
    /// object.
    pub(super) fn who_has(&self, node: &Node, peer: &Peer, data: &[u8]) -> Option<Outgoing> {
        let q = WhoHas::parse(data).ok()?;
        if !q.asks(self.config.device.instance) {
            return None;
        }
        let (object, name) = self.find(node, q.object)?;
        let answer = IHave {
            device: self.config.device.id(),
            object,
            name: &name,
        };
        datagram(peer, false, |w| {
            w.put(&[0x10, unconfirmed::I_HAVE])?;
            answer.emit(w)
        })
        .ok()
    }

    /// The object wanted, and its Object_Name, if the node has it (the Device's wildcard
    /// instance names no object here).
    fn find(&self, node: &Node, wanted: Wanted<'_>) -> Option<(ObjectId, String)> {
        let v = view(node, &self.config, &self.cov_increments);
        let named = |id: ObjectId| v.resolve(id).map(|(class, k)| (id, v.name(class, k)));
        match wanted {
            Wanted::Id(id) if id.object_type == ot::DEVICE && id != self.config.device.id() => None,
            Wanted::Id(id) => named(id),
            Wanted::Name(n) => v
                .object_list()
                .into_iter()
                .filter_map(named)
                .find(|(_, name)| name == n),
        }
    }
}
