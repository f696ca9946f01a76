#!/usr/bin/python3
"""The test overlay that scripts/kube-drill.sh plays with `podman kube play`.

Usage: kube-overlay.py MANIFEST --replicas=N --ports=G,H,M[;G,H,M...]
                       --image=NAME --secrets=DIR

Reads the Deployment of MANIFEST (deploy/kubernetes/riskplan-server.yaml) and
prints N Deployments made from it, named riskplan-server-0 ... N-1, each of
one replica. Everything else of the pod is the manifest's own (arguments,
security context, probes, volumes, grace period, resources); only what a
laptop lacks is changed, and each change is listed in the object's
annotation riskplan.drill/changes:

- hostNetwork: true, and every listening port on 127.0.0.1 (--listen added
  after the image's ENTRYPOINT, --health_listen and --metrics_listen
  rewritten), replica i on its own ports G,H,M: on the host network the
  replicas would otherwise all bind the same ports (podman plays
  `replicas: 3` as three pods, which on one network would collide);
- the container ports and the probes' port follow;
- image: the local image, imagePullPolicy: Never (no registry);
- the Secret volumes become hostPath volumes of DIR/<secretName> (podman
  4.3 writes a Secret's values into its volume still base64-encoded, so
  the PEM files would not parse; the files are what the Secrets would hold).

The Services, the HorizontalPodAutoscaler and the NetworkPolicy are not
played by podman and are left out (docs/deploy.md says how each is checked).
"""
import copy
import sys

import yaml


def fail(msg):
    print(f"kube-overlay: {msg}", file=sys.stderr)
    sys.exit(2)


def main(argv):
    opts = {}
    files = []
    for a in argv[1:]:
        if a.startswith("--") and "=" in a:
            k, v = a[2:].split("=", 1)
            opts[k] = v
        else:
            files.append(a)
    if len(files) != 1 or not {"replicas", "ports", "image", "secrets"} <= opts.keys():
        fail(__doc__.strip().splitlines()[2])
    replicas = int(opts["replicas"])
    ports = [tuple(int(p) for p in triple.split(",")) for triple in opts["ports"].split(";")]
    if len(ports) != replicas or any(len(t) != 3 for t in ports):
        fail(f"--ports needs {replicas} triples G,H,M (gRPC, health, metrics)")
    with open(files[0]) as f:
        docs = [d for d in yaml.safe_load_all(f) if d]
    deployments = [d for d in docs if d.get("kind") == "Deployment"]
    if len(deployments) != 1:
        fail(f"{files[0]}: want exactly one Deployment, found {len(deployments)}")
    base = deployments[0]
    name = base["metadata"]["name"]
    out = []
    for i in range(replicas):
        grpc_port, health_port, metrics_port = ports[i]
        d = copy.deepcopy(base)
        changes = []
        d["metadata"]["name"] = f"{name}-{i}"
        d["spec"]["replicas"] = 1
        changes.append(f"one of {replicas} Deployments of one replica (host network: own ports)")
        pod = d["spec"]["template"]["spec"]
        pod["hostNetwork"] = True
        changes.append("hostNetwork: true")
        containers = pod["containers"]
        if len(containers) != 1:
            fail("want one container in the pod")
        c = containers[0]
        c["image"] = opts["image"]
        c["imagePullPolicy"] = "Never"
        changes.append(f"image {opts['image']}, imagePullPolicy Never")
        args = []
        for a in c.get("args", []):
            if a.startswith("--health_listen="):
                a = f"--health_listen=127.0.0.1:{health_port}"
            elif a.startswith("--metrics_listen="):
                a = f"--metrics_listen=127.0.0.1:{metrics_port}"
            elif a.startswith("--listen="):
                fail("the manifest's args give --listen; the overlay expects the image's")
            args.append(a)
        args.append(f"--listen=127.0.0.1:{grpc_port}")
        c["args"] = args
        changes.append(f"listening on 127.0.0.1 only: gRPC {grpc_port}, health {health_port}, metrics {metrics_port}")
        names = sorted(p.get("name", "") for p in c.get("ports", []))
        if names != ["grpc", "health", "metrics"]:
            fail(f"want the container ports grpc, health and metrics, found {names}")
        # podman 4.3 makes port mappings of a container's ports, which a pod
        # on the host network cannot have ("PortMappings can only be used
        # with Bridge or slirp4netns networking"): they are dropped; the
        # server listens on the ports of its flags above.
        del c["ports"]
        changes.append("container ports dropped (podman: no port mappings on the host network)")
        for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
            if probe in c:
                for kind in ("grpc", "tcpSocket", "httpGet"):
                    if kind in c[probe]:
                        c[probe][kind]["port"] = health_port
        changes.append("the probes on the health port above")
        for v in pod.get("volumes", []):
            if "secret" in v:
                secret = v.pop("secret")["secretName"]
                v["hostPath"] = {"path": f"{opts['secrets']}/{secret}", "type": "Directory"}
                changes.append(f"volume {v['name']}: hostPath of Secret {secret}'s files (podman 4.3 leaves Secret values base64-encoded)")
        d["metadata"].setdefault("annotations", {})["riskplan.drill/changes"] = "; ".join(changes)
        d["metadata"]["labels"] = dict(d["metadata"].get("labels", {}), **{"riskplan.drill/replica": str(i)})
        d["spec"]["template"]["metadata"]["labels"]["riskplan.drill/replica"] = str(i)
        d["spec"]["selector"]["matchLabels"]["riskplan.drill/replica"] = str(i)
        out.append(d)
    yaml.safe_dump_all(out, sys.stdout, sort_keys=False)


if __name__ == "__main__":
    main(sys.argv)
