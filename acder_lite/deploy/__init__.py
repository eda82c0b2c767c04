"""The road to a robot: the policy's export (TorchScript, ONNX-free), the perturbations
of the robustness tests (`perturb`), the tests themselves (`robust`) and their stored
benches (`stored_bench`).

Layer 6: imports every layer below it."""
