"""The stages, one module each in the order data flows: collect → demos → expert → embed → warmup →
imitate → evaluate, and quickstart chaining them. Each reads artifacts, runs an algorithm module and
writes a new artifact version; none prints, and none imports another (quickstart excepted)."""
