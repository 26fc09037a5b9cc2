"""Eclipse Zenoh transport for edged (DESIGN §6).

- `output.ZenohOutput`: publishes estimates, measurements (rate-limited) and health
  under `vessel/<id>/…`, answers queries with the latest value of every key and holds
  the liveliness token `vessel/<id>/alive`.
- `input.ZenohInput`: subscribes to `vessel/<id>/env/current` and configured keys and
  turns them into canonical measurements.
- `commands`: `edged router` and `edged fleet`.

Every zenoh session of the package is configured through `zconfig`, so that the safe
defaults (peer, localhost only, no scouting) and the json5 drop-in merge exist once.
"""
