"""A secured multi-host bus: Zenoh mutual TLS and the fleet's access-control rules (docs/network.md).

Identities are certificate common names, checked by mutual TLS (every side shows a certificate
signed by the fleet's CA):

* ``ground`` (configurable, several allowed): the ground station — the reasoner, the CLI that sends
  missions, displays. Publishes specs (``llmland/<d>/reasoner/spec``) and missions, serves the shared
  ``llmland/@ground/...`` queryables and liveliness, subscribes to everything. It never publishes
  planner commands.
* ``<d>`` (a drone id, e.g. ``d0``): a drone, usually its own router that the drone's sim (and VLE)
  reach on loopback. It may publish only its own ``llmland/<d>/sim/*``, ``vle/*``, ``episode/*``,
  ``mission`` (the sim's echo of the resolved mission) and liveliness keys, receive only its own
  ``planner/*``, ``reasoner/spec`` and ``mission``, and query the shared ``@ground`` services.
* ``planner-<d>``: drone ``<d>``'s planner: the only identity that may publish ``llmland/<d>/planner/*``
  (with ``planner_onboard`` the drone itself may, for a planner flying on the drone).

:func:`access_control` turns a :class:`FleetPolicy` into Zenoh's ``access_control`` config (default
deny; allow rules per subject). Zenoh matches an ACL rule when one of its key expressions *includes*
the message's key, so a wildcard subscription (``llmland/**``) is its own key, and interest
declarations towards drones are allowed broadly (they carry no data); the data itself (``put``,
``query``, ``reply``, liveliness tokens) is filtered per drone on ingress and egress.
Sources: Zenoh manual, "Access Control" (https://zenoh.io/docs/manual/access-control/);
zenoh ``DEFAULT_CONFIG.json5`` (``transport/link/tls``, ``access_control``) and
``zenoh/src/net/routing/interceptor/authorization.rs`` (``nodes_including``), 1.9/1.10.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field, field_validator

from .keys import GROUND_PREFIX, PREFIX, VLE_CAPTION_QUERY, validate_drone_id

#: every message type Zenoh's ACL knows
ALL_MESSAGES = ["put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
                "liveliness_token", "liveliness_query", "declare_liveliness_subscriber"]
#: declarations and queries that carry no data: what a router tells a drone about its interests
INTEREST_MESSAGES = ["declare_subscriber", "declare_liveliness_subscriber", "liveliness_query"]
EVERYTHING = [f"{PREFIX}/**", f"{GROUND_PREFIX}/**"]
PLANNER_ID_PREFIX = "planner-"


def tls_config(root_ca: Path, certificate: Path | None = None, private_key: Path | None = None,
               mtls: bool = True) -> dict[str, Any]:
    """Zenoh's ``transport/link/tls`` block: one certificate for both listening and connecting.

    With ``mtls`` a listener asks every connecting side for a certificate signed by ``root_ca`` and a
    connecting side shows its own (Zenoh sends the client certificate only when ``enable_mtls``).
    """
    for p in (root_ca, certificate, private_key):
        if p is not None and not Path(p).is_file():
            raise FileNotFoundError(f"TLS file not found: {p}")
    if (certificate is None) != (private_key is None):
        raise ValueError("a TLS certificate needs its private key (and the other way round)")
    if mtls and certificate is None:
        raise ValueError("mutual TLS needs this side's certificate and private key")
    block: dict[str, Any] = {"root_ca_certificate": str(root_ca), "enable_mtls": mtls}
    if certificate is not None and private_key is not None:
        block.update({"listen_certificate": str(certificate), "listen_private_key": str(private_key),
                      "connect_certificate": str(certificate), "connect_private_key": str(private_key)})
    return block


class FleetPolicy(BaseModel):
    """Who may do what on the bus (see the module docstring). Identities are certificate common names."""

    ground: list[str] = Field(default_factory=lambda: ["ground"], min_length=1)
    drones: list[str] = Field(default_factory=list)
    #: the planner flies on the drone: the drone's identity may also publish its ``planner/*`` keys
    planner_onboard: bool = False
    #: plain-TCP links count as the ground station (only for a router whose TCP listener is loopback)
    trust_plain_tcp: bool = False

    @field_validator("drones")
    @classmethod
    def _valid_ids(cls, value: list[str]) -> list[str]:
        return [validate_drone_id(d) for d in value]


def _rule(rid: str, messages: list[str], flows: list[str], keys: list[str]) -> dict[str, Any]:
    return {"id": rid, "messages": messages, "flows": flows, "permission": "allow", "key_exprs": keys}


def _drone_rules(d: str, onboard: bool) -> list[dict[str, Any]]:
    own = f"{PREFIX}/{d}"
    publishes = [f"{own}/sim/**", f"{own}/vle/**", f"{own}/episode/**", f"{own}/mission"]
    if onboard:
        publishes.append(f"{own}/planner/**")
    receives = [f"{own}/planner/**", f"{own}/reasoner/spec", f"{own}/mission"]
    return [
        _rule(f"{d}-publish", ["put"], ["ingress"], publishes),
        _rule(f"{d}-alive", ["liveliness_token"], ["ingress"], [f"{own}/alive/**"]),
        _rule(f"{d}-see-alive", ["liveliness_token"], ["egress"], [f"{own}/alive/**", f"{GROUND_PREFIX}/**"]),
        _rule(f"{d}-subscribe", ["declare_subscriber"], ["ingress"], receives),
        _rule(f"{d}-receive", ["put"], ["egress"], receives),
        _rule(f"{d}-interest", INTEREST_MESSAGES, ["egress"], EVERYTHING),
        _rule(f"{d}-ask-ground", ["query", "liveliness_query", "declare_liveliness_subscriber"], ["ingress"],
              [f"{GROUND_PREFIX}/**", f"{own}/**"]),
        _rule(f"{d}-ground-services", ["declare_queryable", "reply"], ["egress"], [f"{GROUND_PREFIX}/**"]),
        # the drone's VLE serves the shared caption queryable (the reasoner's ``POST /v1/spec``)
        _rule(f"{d}-serve-captions", ["declare_queryable", "reply"], ["ingress"], [VLE_CAPTION_QUERY]),
        _rule(f"{d}-caption-queries", ["query"], ["egress"], [VLE_CAPTION_QUERY]),
    ]


def _planner_rules(d: str) -> list[dict[str, Any]]:
    own = f"{PREFIX}/{d}"
    pid = f"{PLANNER_ID_PREFIX}{d}"
    return [
        _rule(f"{pid}-publish", ["put"], ["ingress"], [f"{own}/planner/**"]),
        _rule(f"{pid}-alive", ["liveliness_token"], ["ingress"], [f"{own}/alive/planner"]),
        _rule(f"{pid}-subscribe", ["declare_subscriber"], ["ingress"], [f"{own}/**"]),
        _rule(f"{pid}-receive", ["put"], ["egress"], [f"{own}/**"]),
        _rule(f"{pid}-interest", INTEREST_MESSAGES, ["egress"], EVERYTHING),
        _rule(f"{pid}-ask-ground", ["query", "liveliness_query", "declare_liveliness_subscriber"], ["ingress"],
              [f"{GROUND_PREFIX}/**", f"{own}/**"]),
        _rule(f"{pid}-ground-services", ["declare_queryable", "reply", "liveliness_token"], ["egress"],
              [f"{GROUND_PREFIX}/**", f"{own}/**"]),
    ]


def _ground_rules() -> list[dict[str, Any]]:
    non_data = [m for m in ALL_MESSAGES if m not in ("put", "delete")]
    return [
        _rule("ground-publish", ["put"], ["ingress"],
              [f"{PREFIX}/*/reasoner/spec", f"{PREFIX}/*/mission", f"{GROUND_PREFIX}/**"]),
        _rule("ground-serve", non_data, ["ingress"], EVERYTHING),
        _rule("ground-see-all", ALL_MESSAGES, ["egress"], EVERYTHING),
    ]


def access_control(policy: FleetPolicy) -> dict[str, Any]:
    """Zenoh's ``access_control`` config block for ``policy`` (enabled, default deny)."""
    rules = _ground_rules()
    ground_subjects: list[dict[str, Any]] = [{"id": "ground", "cert_common_names": list(policy.ground)}]
    if policy.trust_plain_tcp:
        ground_subjects.append({"id": "ground-plain-tcp", "link_protocols": ["tcp"]})
    subjects = list(ground_subjects)
    policies: list[dict[str, Any]] = [{"id": "ground", "rules": [r["id"] for r in rules],
                                       "subjects": [s["id"] for s in ground_subjects]}]
    for d in policy.drones:
        for ident, drules in ((d, _drone_rules(d, policy.planner_onboard)),
                              (f"{PLANNER_ID_PREFIX}{d}", _planner_rules(d))):
            rules += drules
            subjects.append({"id": ident, "cert_common_names": [ident]})
            policies.append({"id": ident, "rules": [r["id"] for r in drules], "subjects": [ident]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}
