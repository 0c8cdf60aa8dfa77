"""A local ensemble cluster takes a free port for the scheduler's HTTP server: a busy 8787 (another dask
cluster or a notebook on the same machine) gives no "Port 8787 is already in use" warning."""
import socket
import warnings

import distributed


def test_local_cluster_with_port_8787_taken_starts_without_a_port_warning():
    from breachflow.ensemble.execute import _quiet_distributed, local_cluster

    blocker = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        blocker.bind(("0.0.0.0", 8787))
        blocker.listen(1)
    except OSError:
        pass  # already taken by another process: the same condition
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cluster = local_cluster(1)
        try:
            port = cluster.scheduler.http_server.port
            with distributed.Client(cluster) as c:
                assert c.submit(sum, [1, 2]).result() == 3
        finally:
            with _quiet_distributed():
                cluster.close()
    finally:
        blocker.close()
    assert port != 8787
    assert not [w for w in caught if "already in use" in str(w.message)], [str(w.message) for w in caught]
