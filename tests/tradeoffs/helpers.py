"""Models shared by the trade-off tests and the fan-out tests.

``CHOICE``: the defender picks once between ``safe`` (cost 10, success 0.9) and ``cheap`` (cost 1,
success 1/2); its fronts are derived by hand in tests/tradeoffs/test_defence.py.
"""

CHOICE = """pomdp
observables s endobservables
module m
  s : [0..2] init 0;
  [safe]  s=0 -> 0.9:(s'=1) + 0.1:(s'=2);
  [cheap] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [end]   s>0 -> true;
endmodule
label "goal" = s=1;
label "done" = s>0;
rewards "cost"
  [safe] true : 10;
  [cheap] true : 1;
endrewards
"""
