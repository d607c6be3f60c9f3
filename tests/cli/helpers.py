"""Models shared by the CLI tests and the fan-out tests."""

# by hand: x=0 moves to x=1 with p, else to x=2; x=1 always moves to x=2. So P(F x=2) = 1,
# P(F (x=1 & X x=2)) = p, and the expected steps until x=2 are 1 + p
CHAIN = """dtmc
const double p;
module m
  x : [0..2] init 0;
  [] x<2 -> p : (x'=x+1) + 1-p : (x'=2);
  [] x=2 -> true;
endmodule
rewards "steps" x<2 : 1; endrewards
"""
