"""Small models shared by the checking tests, each with its values derived by hand."""

from __future__ import annotations

# s0 chooses a (cost 1): s1 or s2 with 1/2 each, or b (free): s2. A strategy taking a with
# probability q has P(F s=1) = q/2 and expected cost q.
GAMBLE = """mdp
module m
  s : [0..2] init 0;
  [a] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [b] s=0 -> (s'=2);
  [] s>0 -> true;
endmodule
rewards "cost" [a] true : 1; endrewards
"""
