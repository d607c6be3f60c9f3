"""`ray start` for a node of CI's two-node Ray cluster on this machine, bound to loopback only.

Ray binds its servers to 127.0.0.1 only when the node's address is 127.0.0.1, and it rewrites
that address to the machine's network address unless RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 —
which in turn refuses a second node. This wrapper runs Ray's own `ray start` command with the
node's address taken as given, so both nodes (and their raylets and object stores) listen on
127.0.0.1 and nothing is reachable from the network. Usage: python .ci/ray_node.py start ...
"""

import sys

from ray._private import ray_constants, services
from ray.scripts.scripts import main

ray_constants.ENABLE_RAY_CLUSTER = True  # the second node may join
services.resolve_ip_for_localhost = lambda host: host
services.get_node_ip_address = lambda address=None: "127.0.0.1"

sys.exit(main())
