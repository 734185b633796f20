"""ascc_common.ports: master and server ports below the kernel's ephemeral range."""
import socket

from ascc_common import ports


def test_free_port_is_free_and_below_the_ephemeral_range():
    start = ports.ephemeral_start()
    seen = set()
    for _ in range(20):
        port = ports.free_port()
        seen.add(port)
        with socket.socket() as s:
            s.bind(("127.0.0.1", port))  # nothing holds it
        if start is not None:
            assert max(1024, start - 12000) <= port < start
    assert len(seen) > 1  # drawn, not one fixed port


def test_a_port_in_use_is_not_given(monkeypatch):
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        taken = held.getsockname()[1]
        monkeypatch.setattr(ports, "ephemeral_start", lambda: taken + 1)
        # the range [taken + 1 - 12000, taken + 1) holds the taken port: never returned
        assert all(ports.free_port() != taken for _ in range(50))


def test_ephemeral_start_read_and_fallback(tmp_path, monkeypatch):
    f = tmp_path / "range"
    f.write_text("40000\t50000\n")
    assert ports.ephemeral_start(str(f)) == 40000
    assert ports.ephemeral_start(str(tmp_path / "missing")) is None
    f.write_text("garbage\n")
    assert ports.ephemeral_start(str(f)) is None
    monkeypatch.setattr(ports, "ephemeral_start", lambda: None)
    port = ports.free_port()  # the OS's choice
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))
