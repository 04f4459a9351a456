"""Online: the twin's online compensator (`twin.sim.online`) behind a robot's real-time interface.

Modules: `cycle` (what every interface shares: the controller's axes in, the correction in the base frame out;
the `Server` protocol), `rsi` (KUKA RSI: XML over UDP, each `<Rob>` packet answered with `RKorr` and its `IPOC`),
`egm` (ABB EGM path correction: protobuf over UDP), `val3` and `alter_protocol` (Stäubli VAL3 `alter`: binary
frames over TCP), `source` and `rdt` (the F/T sample from the sensor's own stream: ATI Net F/T RDT).
"""
