#!/bin/sh
# Runs a command in network and mount namespaces of its own, inside a user
# namespace (no root needed), with loopback up and 127.0.0.1 to 127.0.0.16
# on it; the command may mount (a small tmpfs for a full disk) unseen outside. The
# tests that serve GigE Vision cameras use it: a served camera takes port
# 3956 of its address, so tests running side by side must not share one
# loopback, and a rig's cameras need an address each. Nothing the command
# opens outlives the namespace.
set -e
exec unshare --user --map-root-user --net --mount sh -c '
  ip link set lo up
  i=2
  while [ $i -le 16 ]; do ip addr add 127.0.0.$i/8 dev lo; i=$((i + 1)); done
  exec "$@"' sh "$@"
