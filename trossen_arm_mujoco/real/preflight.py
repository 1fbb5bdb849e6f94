"""What ``replay-real`` checks before anything connects or moves, besides the trajectory
(:mod:`.validate`) and its outputs (:func:`.report.check_outputs`): the arms' addresses and
the episode's step period. Each mistake is one line naming what to change.

Docs: docs/cli/replay-real.md.
"""

from __future__ import annotations

import ipaddress
import math
from typing import Any

from trossen_arm_mujoco.errors import UserError

__all__ = ["check_arm_ips", "check_ip", "check_loopback", "recorded_dt"]


def check_loopback(ip: object, flag: str = "address") -> str:
    """``ip`` normalized when it is an IPv4 address in 127.0.0.0/8, else a one-line
    ``UserError`` naming ``flag``: the simulated kit (its arms, cameras and control channel)
    is served, and talked to, on this machine only."""
    try:
        address = ipaddress.ip_address(str(ip).strip())
    except ValueError:
        address = None
    if not isinstance(address, ipaddress.IPv4Address) or not address.is_loopback:
        raise UserError(
            f"{flag} {ip!r} is not an IPv4 loopback address: the simulated kit is served on "
            "this machine only; use an address in 127.0.0.0/8, e.g. 127.0.0.2"
        )
    return str(address)


def check_ip(ip: object, flag: str) -> str:
    """``ip`` as the arm controller's IPv4 address, checked before anything connects.

    ``trossen_arm`` takes a bare IPv4 address (its ports are fixed), so a port, a host
    name, an out-of-range number or an empty value is refused here, in one line naming
    ``flag``, instead of failing inside the driver.

    Returns:
        The address, normalized (``" 127.0.0.1 "`` -> ``"127.0.0.1"``).

    Raises:
        UserError: ``<flag> '<ip>' is not an IPv4 address ...``.
    """
    text = str(ip).strip() if ip is not None else ""
    try:
        address = ipaddress.IPv4Address(text)
    except ValueError:
        if not text:
            why = "it is empty"
        elif ":" in text:
            why = "give the address alone: the driver uses the controller's fixed ports"
        else:
            why = "four numbers 0-255 separated by dots are expected"
        raise UserError(
            f"{flag} {text!r} is not an IPv4 address ({why}); pass the arm controller's "
            f"address, e.g. {flag} 192.168.1.5"
        ) from None
    if (
        address.is_unspecified
        or address.is_multicast
        or address == ipaddress.IPv4Address("255.255.255.255")
    ):
        raise UserError(
            f"{flag} {text!r} cannot be an arm controller's address; pass the arm "
            f"controller's address, e.g. {flag} 192.168.1.5"
        )
    return str(address)


def check_arm_ips(ips: dict[str, object], flags: dict[str, str]) -> dict[str, str]:
    """Both arms' addresses checked by :func:`check_ip`, and different from each other.

    Args:
        ips: ``{"left": address, "right": address}``.
        flags: the flag naming each address (``{"left": "--left_ip", ...}``).

    Raises:
        UserError: one line naming the flag at fault.
    """
    out = {side: check_ip(ips[side], flags[side]) for side in ("left", "right")}
    if out["left"] == out["right"]:
        raise UserError(
            f"{flags['left']} and {flags['right']} are both {out['left']}; each arm has its "
            f"own controller: give each its address"
        )
    return out


def recorded_dt(episode: Any) -> float:
    """The step period (s) of ``episode`` (a ``data.reader.Episode``: ``real`` sits beside
    ``data`` and does not import it), checked: positive and finite.

    Raises:
        UserError: naming the file and its ``dt`` attribute (zero, negative, NaN, inf,
            or not a number).
    """
    try:
        dt = float(episode.dt)
    except (TypeError, ValueError):
        dt = math.nan
    if not (math.isfinite(dt) and dt > 0):
        raw: Any = episode.attrs.get("dt")
        raise UserError(
            f"{episode.path}: attribute 'dt' is {raw!r}; expected the step period in s, a "
            f"positive finite number (e.g. 0.02 for 50 Hz): fix or delete the attribute"
        )
    return dt
