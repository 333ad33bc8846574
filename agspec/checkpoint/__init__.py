"""What a training run leaves behind, loadable without the training loop (spec/16-training.md, T-RUN-DIR).

The run directory's format (:mod:`.rundir`, torch-free), checkpoint and policy files (:mod:`.files`), the
networks of tab:marlconfig (:mod:`.nets`) and a trained network as an evaluable policy factory
(:mod:`.policy`, T-EVAL-ACTION).  ``agspec evaluate --policy RUN_DIR`` (F-POLICY-CHECKPOINT) reads these
and never imports :mod:`agspec.train`, which builds on them.
"""
