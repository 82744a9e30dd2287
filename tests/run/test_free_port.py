"""``free_port`` hands out ports the kernel does not hand out by itself.

An observer in the suite found the port it had been given taken before it listened ("Address already in
use"): ``bind(0)`` had picked it from the ephemeral range, where the kernel picks again at once for other
processes' outgoing connections. Ports come from just below that range now.
"""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from bimbot import supervisor
from bimbot.supervisor import FREE_PORT_SPAN, free_port


def _ephemeral_low() -> int:
    return int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])


def test_ports_come_from_below_the_ephemeral_range_and_can_be_bound() -> None:
    low = _ephemeral_low()
    ports = [free_port() for _ in range(20)]
    assert all(max(1024, low - FREE_PORT_SPAN) <= port < low for port in ports), (low, ports)
    assert len(set(ports)) > 15  # random picks, not one port over and over
    for port in ports[:5]:
        with socket.socket() as sock:
            sock.bind(("127.0.0.1", port))  # free when handed out


def test_a_taken_port_is_not_handed_out(monkeypatch: pytest.MonkeyPatch) -> None:
    low = _ephemeral_low()
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", low - 1))
        taken.listen()
        monkeypatch.setattr(supervisor, "FREE_PORT_SPAN", 1)  # the only candidate is the taken port
        port = free_port()
    assert port != low - 1 and port > 0  # the kernel's choice, as before


def test_without_the_kernel_range_it_assumes_linux_default(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(supervisor, "EPHEMERAL_RANGE_FILE", tmp_path / "missing")
    assert 32768 - FREE_PORT_SPAN <= free_port() < 32768
