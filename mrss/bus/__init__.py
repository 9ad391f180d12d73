"""The MRSS message bus: a ZeroMQ XSUB/XPUB proxy, publish/subscribe, a reliable channel.

```
ep = BusEndpoints.ipc(run_dir)                 # or BusEndpoints.tcp("127.0.0.1", p1, p2)
run_proxy(ep, stop=event)                      # or: python -m mrss.bus.proxy --run-dir DIR
pub = Publisher(ep, src="rcl", inc=3); pub.publish(msg)
sub = Subscriber(ep, prefixes=["action.status"]); env = sub.recv(timeout=1.0)
tx = ReliableSender(ep, src="reasoner", channel="action"); tx.send(msg)
rx = ReliableReceiver(ep, src="rcl", channel="action", handler=fn)
```
See docs/bus.md.
"""

from mrss.bus.endpoints import BusEndpoints
from mrss.bus.forwarder import ProxyThread, run_proxy
from mrss.bus.incarnations import Incarnations, Stale
from mrss.bus.publisher import Publisher
from mrss.bus.reliable_receiver import NotHandled, ReliableReceiver
from mrss.bus.reliable_sender import ReliableSender
from mrss.bus.subscriber import Subscriber

__all__ = [
    "BusEndpoints", "Incarnations", "NotHandled", "ProxyThread", "Publisher", "ReliableReceiver",
    "ReliableSender", "Stale",
    "Subscriber", "run_proxy",
]
