"""Evaluating a user's policy under the official protocol (spec/13-policy.md, F-POLICY-*).

``contract``  what ``--policy`` names (F-POLICY-SPEC) and the errors a misbehaving policy gets;
``sessions``  one episode's decision maker: a reference controller, an in-process PettingZoo
              policy (F-POLICY-PYTHON) or a policy process (F-POLICY-PROTOCOL);
``stats``     summaries and the paired comparison (F-POLICY-COMPARISON);
``bundle``    the results bundle (F-POLICY-BUNDLE); ``published`` the paper's rows;
``tables`` / ``figure``  the paper's table and figure with the user's rows.
"""
