"""A free TCP port on loopback, for a ROS master or a server a script starts itself (so
that benchmarks and tests run side by side never share a master).

The port is drawn below the kernel's ephemeral range (``ip_local_port_range``, 32768-60999
on Linux by default). Every rospy node binds its XML-RPC and TCPROS servers to port 0,
i.e. to an ephemeral port: a master port taken from that range could be given to a node
of a launch running beside, between the moment it is chosen and the moment the master
binds it, and a client would then talk to that node instead of a master (seen in a
clean-clone CI: 'method "getTopicTypes" is not supported').

Run as a script, it prints one (scripts/ros_isolation.sh)."""
import random
import socket

_RANGE_FILE = "/proc/sys/net/ipv4/ip_local_port_range"
_BELOW = 12000  # ports drawn from [ephemeral start - _BELOW, ephemeral start)


def ephemeral_start(path: str = _RANGE_FILE):
    """The first port of the kernel's ephemeral range, or None where it cannot be read."""
    try:
        with open(path) as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def _bindable(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def free_port(tries: int = 200) -> int:
    """A TCP port on 127.0.0.1 that no socket is bound to now, below the ephemeral range
    (see above); the OS's choice where that range is unknown or nothing free was found."""
    start = ephemeral_start()
    if start is not None and start > 2048:
        rng = random.SystemRandom()
        for _ in range(tries):
            port = rng.randrange(max(1024, start - _BELOW), start)
            if _bindable(port):
                return port
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


if __name__ == "__main__":
    print(free_port())
