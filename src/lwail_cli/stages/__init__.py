"""The stages, one module each in the order data flows: collect → demos → expert → embed → warmup →
imitate → evaluate (and export, curve, report). Each reads artifacts, runs an algorithm module and writes a new
artifact version; none prints. None imports another but ``chain`` (the chain's stages in order) and the two that
run it, ``quickstart`` and ``sweep`` (with its plan, ``sweep_plan``); ``online`` (the run skeleton of expert and
imitate) and ``shared`` are helpers, not stages."""
