//! Opening the router's endpoints, at start and at a reload.

use super::*;

/// An endpoint the router opened from a [`link`] URI, with its number.
pub(super) struct Opened {
    pub config: EndpointConfig,
    pub index: usize,
    _handle: link::Handle,
}

/// Opens `endpoint` as a new endpoint of the router.
pub(super) fn open_endpoint(
    state: &Arc<Mutex<State>>,
    endpoint: &EndpointConfig,
    options: link::Options,
) -> io::Result<Opened> {
    let link = LinkConfig {
        datagrams: endpoint.endpoint.is_datagrams(),
        ..endpoint.link.clone()
    };
    let peers = match endpoint.endpoint {
        link::Endpoint::UdpIn(..) => Peers::OnProbation,
        link::Endpoint::UdpBcast(..) | link::Endpoint::UdpMcast(..) => Peers::Group,
        link::Endpoint::TcpIn(..) => Peers::Clients,
        _ => Peers::Kept,
    };
    let index = lock(state).add_endpoint(link, peers);
    let shared = state.clone();
    let sink: link::Sink = Arc::new(move |event| {
        lock(&shared).handle(event);
        true
    });
    match link::open(index, &endpoint.endpoint, options, sink) {
        Ok(handle) => Ok(Opened {
            config: endpoint.clone(),
            index,
            _handle: handle,
        }),
        Err(e) => {
            lock(state).remove_endpoint(index);
            Err(e)
        }
    }
}

/// Applies a reloaded list of endpoints: those configured exactly as before keep running with
/// their peers; the others close, and new ones open (one that cannot open is reported and
/// left out).
pub(super) fn reload(
    state: &Arc<Mutex<State>>,
    opened: &mut Vec<Opened>,
    endpoints: &[EndpointConfig],
    options: link::Options,
) {
    let mut keep = vec![false; opened.len()];
    let mut new = Vec::new();
    for e in endpoints {
        match (0..opened.len()).find(|&i| !keep[i] && opened[i].config == *e) {
            Some(i) => keep[i] = true,
            None => new.push(e),
        }
    }
    let mut kept = Vec::new();
    for (o, keep) in opened.drain(..).zip(keep) {
        if keep {
            kept.push(o);
        } else {
            say(format!("reload: closing {}", o.config.endpoint));
            lock(state).remove_endpoint(o.index);
        }
    }
    *opened = kept;
    for e in new {
        match open_endpoint(state, e, options) {
            Ok(o) => {
                say(format!("reload: opened {}", e.endpoint));
                opened.push(o);
            }
            Err(err) => say(format!("reload: cannot open {}: {err}", e.endpoint)),
        }
    }
}
