"""A free TCP port on loopback, for a ROS master or a server a script starts itself (so
that benchmarks and tests run side by side never share a master)."""
import socket


def free_port() -> int:
    """A TCP port on 127.0.0.1 that no socket is bound to now (the OS's choice)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
