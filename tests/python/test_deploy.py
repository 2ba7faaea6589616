"""The cluster files in deploy/, checked offline with what the tools offer: the Ray cluster
launcher YAML with Ray's own schema and defaults, the KubeRay RayJob's pod templates with
Kubernetes' schema (kubernetes-validate, strict), its own fields against KubeRay's v1 API
names, and every command they run against panda-rapier's parser. Nothing is launched."""

from __future__ import annotations

import re
import shlex
from pathlib import Path
from typing import Any

import pytest

yaml = pytest.importorskip("yaml")
pytest.importorskip("ray", reason="needs Ray: pip install '.[rllib]'")

ROOT = Path(__file__).resolve().parents[2]
DEPLOY = ROOT / "deploy"


def _ray_pin() -> str:
    text = (ROOT / "pyproject.toml").read_text()
    match = re.search(r'"ray\[rllib,tune\]==([0-9.]+)"', text)
    assert match, "the rllib extra pins ray"
    return match.group(1)


def test_cluster_launcher_yaml_passes_rays_schema() -> None:
    from ray.autoscaler._private.util import prepare_config, validate_config

    config = yaml.safe_load((DEPLOY / "ray-cluster-aws.yaml").read_text())
    prepared = prepare_config(config)
    validate_config(prepared)
    assert prepared["head_node_type"] in prepared["available_node_types"]
    assert prepared["available_node_types"]["head"]["resources"] == {"CPU": 0}
    setup = " ".join(prepared["setup_commands"])
    assert f"ray[default,rllib,tune]=={_ray_pin()}" in setup
    assert "panda_rapier-" in setup and "[train,rllib]" in setup
    # A broken file fails the same check.
    broken = {**config, "available_node_types": {"head": {"node_config": {}}}}
    with pytest.raises(Exception, match=r"resources|max_workers|head"):
        validate_config(prepare_config(broken))


#: KubeRay's v1 API (ray.io/v1): the RayJob, RayClusterSpec and group fields this file may use.
RAYJOB_SPEC = {
    "entrypoint",
    "shutdownAfterJobFinishes",
    "ttlSecondsAfterFinished",
    "activeDeadlineSeconds",
    "backoffLimit",
    "runtimeEnvYAML",
    "submissionMode",
    "rayClusterSpec",
    "clusterSelector",
    "suspend",
    "entrypointNumCpus",
    "submitterPodTemplate",
}
CLUSTER_SPEC = {"rayVersion", "headGroupSpec", "workerGroupSpecs", "enableInTreeAutoscaling"}
HEAD_GROUP = {"rayStartParams", "template", "serviceType"}
WORKER_GROUP = {
    "groupName",
    "replicas",
    "minReplicas",
    "maxReplicas",
    "rayStartParams",
    "template",
}


def _pod_template_is_valid(template: dict[str, Any]) -> None:
    import kubernetes_validate

    resource = {
        "apiVersion": "v1",
        "kind": "PodTemplate",
        "metadata": {"name": "check"},
        "template": template,
    }
    kubernetes_validate.validate(resource, "1.30.0", strict=True)


def test_rayjob_manifest_is_kuberay_v1_with_valid_pods() -> None:
    pytest.importorskip("kubernetes_validate", reason="pip install kubernetes-validate")
    import kubernetes_validate

    job = yaml.safe_load((DEPLOY / "rayjob.yaml").read_text())
    assert job["apiVersion"] == "ray.io/v1" and job["kind"] == "RayJob"
    spec = job["spec"]
    assert set(spec) <= RAYJOB_SPEC
    cluster = spec["rayClusterSpec"]
    assert set(cluster) <= CLUSTER_SPEC and cluster["rayVersion"] == _ray_pin()
    head = cluster["headGroupSpec"]
    assert set(head) <= HEAD_GROUP
    assert all(isinstance(v, str) for v in head["rayStartParams"].values())
    _pod_template_is_valid(head["template"])
    for group in cluster["workerGroupSpecs"]:
        assert set(group) <= WORKER_GROUP
        assert group["minReplicas"] <= group["replicas"] <= group["maxReplicas"]
        _pod_template_is_valid(group["template"])
    # The check can fail: a misspelt container field is refused.
    bad = yaml.safe_load(yaml.safe_dump(head["template"]))
    bad["spec"]["containers"][0]["imagePullPolicyy"] = "Always"
    with pytest.raises(kubernetes_validate.ValidationError):
        _pod_template_is_valid(bad)


def test_deployed_commands_parse() -> None:
    from panda_rapier.cli import _parser

    job = yaml.safe_load((DEPLOY / "rayjob.yaml").read_text())
    words = shlex.split(job["spec"]["entrypoint"])
    assert words[0] == "panda-rapier"
    args = _parser().parse_args(words[1:])
    assert (args.algo, args.backend, args.address) == ("ppo", "rllib", "auto")
    image = (DEPLOY / "Dockerfile").read_text()
    assert f"FROM rayproject/ray:{_ray_pin()}-" in image
