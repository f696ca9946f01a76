#!/usr/bin/python3
"""grpc.health.v1.Health/Check of a server, as Kubernetes' gRPC probe asks it.

Usage: grpc-health.py HOST:PORT [SERVICE] [--timeout=S]

Prints the status (SERVING, NOT_SERVING, UNKNOWN, SERVICE_UNKNOWN) and exits 0
when it is SERVING, 1 otherwise; a failed call prints its gRPC code and
details and exits 2. Plaintext, as the kubelet's probe (riskplan-server's
--health_listen port). The messages are encoded by hand (field 1 of each, a
string and an enum), so python3-grpcio (Debian 12) is all it needs.
"""
import sys

import grpc

STATUS = {0: "UNKNOWN", 1: "SERVING", 2: "NOT_SERVING", 3: "SERVICE_UNKNOWN"}


def encode_request(service: str) -> bytes:
    data = service.encode()
    if not data:
        return b""
    if len(data) > 127:
        raise ValueError("service name longer than 127 bytes")
    return b"\x0a" + bytes([len(data)]) + data


def decode_status(data: bytes) -> int:
    # HealthCheckResponse { ServingStatus status = 1; } ; absent = 0.
    if not data:
        return 0
    if data[0] != 0x08 or len(data) < 2:
        raise ValueError(f"unexpected response bytes {data!r}")
    return data[1]


def main(argv):
    args = [a for a in argv[1:] if not a.startswith("--")]
    timeout = 2.0
    for a in argv[1:]:
        if a.startswith("--timeout="):
            timeout = float(a.split("=", 1)[1])
        elif a.startswith("--"):
            print(f"grpc-health: unknown flag {a}", file=sys.stderr)
            return 2
    if not 1 <= len(args) <= 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    service = args[1] if len(args) == 2 else ""
    with grpc.insecure_channel(args[0]) as channel:
        check = channel.unary_unary(
            "/grpc.health.v1.Health/Check",
            request_serializer=lambda x: x,
            response_deserializer=lambda x: x,
        )
        try:
            reply = check(encode_request(service), timeout=timeout)
        except grpc.RpcError as e:
            print(f"{e.code().name}: {e.details()}")
            return 2
    status = decode_status(reply)
    print(STATUS.get(status, f"status {status}"))
    return 0 if status == 1 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
