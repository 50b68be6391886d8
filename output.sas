begin_version
3
end_version
begin_metric
0
end_metric
3
begin_variable
var0
-1
80
Atom at(s11393)
Atom at(s12193)
Atom at(s12196)
Atom at(s12593)
Atom at(s12596)
Atom at(s133)
Atom at(s1352)
Atom at(s1353)
Atom at(s136)
Atom at(s1371)
Atom at(s1375)
Atom at(s1393)
Atom at(s1395)
Atom at(s1434)
Atom at(s151)
Atom at(s154)
Atom at(s155)
Atom at(s158)
Atom at(s1751)
Atom at(s1753)
Atom at(s1755)
Atom at(s1771)
Atom at(s1793)
Atom at(s1794)
Atom at(s1835)
Atom at(s193)
Atom at(s196)
Atom at(s199)
Atom at(s2109)
Atom at(s2110)
Atom at(s2127)
Atom at(s2131)
Atom at(s2132)
Atom at(s2149)
Atom at(s2153)
Atom at(s2154)
Atom at(s2171)
Atom at(s2193)
Atom at(s231)
Atom at(s233)
Atom at(s234)
Atom at(s235)
Atom at(s236)
Atom at(s238)
Atom at(s2486)
Atom at(s2488)
Atom at(s2509)
Atom at(s2527)
Atom at(s2549)
Atom at(s2927)
Atom at(s2949)
Atom at(s3327)
Atom at(s3349)
Atom at(s3687)
Atom at(s3688)
Atom at(s3709)
Atom at(s3710)
Atom at(s3727)
Atom at(s3729)
Atom at(s3749)
Atom at(s3751)
Atom at(s3767)
Atom at(s4086)
Atom at(s4088)
Atom at(s4105)
Atom at(s4109)
Atom at(s4127)
Atom at(s4486)
Atom at(s4487)
Atom at(s4509)
Atom at(s4525)
Atom at(s4527)
Atom at(s4545)
Atom at(s4927)
Atom at(s5327)
Atom at(s571)
Atom at(s5727)
Atom at(s593)
Atom at(s993)
Atom at(s996)
end_variable
begin_variable
var1
-1
2
Atom visited(g1)
NegatedAtom visited(g1)
end_variable
begin_variable
var2
-1
2
Atom visited(g0)
NegatedAtom visited(g0)
end_variable
0
begin_state
26
1
1
end_state
begin_goal
2
1 0
2 0
end_goal
103
begin_operator
move s1393 s12593 lat-straight-rm45p0
0
1
0 0 11 3
1
end_operator
begin_operator
move s1393 s1352 lat-straight-t025-a180
0
1
0 0 11 6
1
end_operator
begin_operator
move s1393 s1353 lat-straight-t025-a135
0
1
0 0 11 7
1
end_operator
begin_operator
move s1393 s1375 lat-straight-t025-a090
0
1
0 0 11 10
1
end_operator
begin_operator
move s1393 s1395 lat-straight-t025-a045
0
1
0 0 11 12
1
end_operator
begin_operator
move s1393 s1434 lat-straight-t025-a000
0
1
0 0 11 13
1
end_operator
begin_operator
move s1393 s2193 lat-straight-rp22p5
0
1
0 0 11 37
1
end_operator
begin_operator
move s1393 s593 lat-straight-rm22p5
0
1
0 0 11 77
1
end_operator
begin_operator
move s1393 s993 lat-straight-rm05p6
0
1
0 0 11 78
1
end_operator
begin_operator
move s1793 s1393 lat-straight-rm05p6
0
1
0 0 22 11
1
end_operator
begin_operator
move s1793 s1751 lat-straight-t025-a180
0
1
0 0 22 18
1
end_operator
begin_operator
move s1793 s1753 lat-straight-t025-a135
0
1
0 0 22 19
1
end_operator
begin_operator
move s1793 s1755 lat-straight-t025-a090
0
1
0 0 22 20
1
end_operator
begin_operator
move s1793 s1794 lat-straight-t005-a045
0
1
0 0 22 23
1
end_operator
begin_operator
move s1793 s1835 lat-straight-t025-a000
0
1
0 0 22 24
1
end_operator
begin_operator
move s1793 s193 lat-straight-rm45p0
0
1
0 0 22 25
1
end_operator
begin_operator
move s1793 s993 lat-straight-rm22p5
0
1
0 0 22 78
1
end_operator
begin_operator
move s193 s11393 lat-straight-rm45p0
0
1
0 0 25 0
1
end_operator
begin_operator
move s193 s12193 lat-straight-rm22p5
0
1
0 0 25 1
1
end_operator
begin_operator
move s193 s12593 lat-straight-rm05p6
0
1
0 0 25 3
1
end_operator
begin_operator
move s193 s133 lat-straight-t025-a180
0
1
0 0 25 5
1
end_operator
begin_operator
move s193 s151 lat-straight-t025-a225
0
1
0 0 25 14
1
end_operator
begin_operator
move s193 s155 lat-straight-t025-a135
0
1
0 0 25 16
1
end_operator
begin_operator
move s193 s1793 lat-straight-rp45p0
0
1
0 0 25 22
1
end_operator
begin_operator
move s193 s196 lat-straight-t025-a090
0
1
0 0 25 26
1
end_operator
begin_operator
move s193 s231 lat-straight-t025-a315
0
1
0 0 25 38
1
end_operator
begin_operator
move s193 s233 lat-straight-t025-a000
0
1
0 0 25 39
1
end_operator
begin_operator
move s193 s235 lat-straight-t025-a045
0
1
0 0 25 41
1
end_operator
begin_operator
move s193 s993 lat-straight-rp22p5
0
1
0 0 25 78
1
end_operator
begin_operator
move s196 s12196 lat-straight-rm22p5
0
1
0 0 26 2
1
end_operator
begin_operator
move s196 s12596 lat-straight-rm05p6
0
1
0 0 26 4
1
end_operator
begin_operator
move s196 s136 lat-straight-t025-a180
0
1
0 0 26 8
1
end_operator
begin_operator
move s196 s154 lat-straight-t025-a225
0
1
0 0 26 15
1
end_operator
begin_operator
move s196 s158 lat-straight-t025-a135
0
1
0 0 26 17
1
end_operator
begin_operator
move s196 s193 lat-straight-t025-a270
0
1
0 0 26 25
1
end_operator
begin_operator
move s196 s199 lat-straight-t025-a090
0
1
0 0 26 27
1
end_operator
begin_operator
move s196 s234 lat-straight-t025-a315
0
1
0 0 26 40
1
end_operator
begin_operator
move s196 s236 lat-straight-t025-a000
0
1
0 0 26 42
1
end_operator
begin_operator
move s196 s238 lat-straight-t025-a045
0
1
0 0 26 43
1
end_operator
begin_operator
move s196 s996 lat-straight-rp22p5
0
1
0 0 26 79
1
end_operator
begin_operator
move s2149 s2109 lat-straight-t025-a135
0
1
0 0 33 28
1
end_operator
begin_operator
move s2149 s2110 lat-straight-t025-a090
0
1
0 0 33 29
1
end_operator
begin_operator
move s2149 s2127 lat-straight-t025-a180
0
1
0 0 33 30
1
end_operator
begin_operator
move s2149 s2131 lat-straight-t025-a045
0
1
0 0 33 31
1
end_operator
begin_operator
move s2149 s2171 lat-straight-t025-a000
0
1
0 0 33 36
1
end_operator
begin_operator
move s2149 s2949 lat-straight-rp22p5
0
1
0 0 33 50
1
end_operator
begin_operator
move s2149 s3749 lat-straight-rp45p0
0
1
0 0 33 59
1
end_operator
begin_operator
move s2171 s1371 lat-straight-rm22p5
0
1
0 0 36 9
1
end_operator
begin_operator
move s2171 s1771 lat-straight-rm05p6
0
1
0 0 36 21
1
end_operator
begin_operator
move s2171 s2131 lat-straight-t025-a135
0
1
0 0 36 31
1
end_operator
begin_operator
move s2171 s2132 lat-straight-t025-a090
0
1
0 0 36 32
1
end_operator
begin_operator
move s2171 s2149 lat-straight-t025-a180
0
1
0 0 36 33
1
end_operator
begin_operator
move s2171 s2153 lat-straight-t025-a045
0
1
0 0 36 34
1
end_operator
begin_operator
move s2171 s2193 lat-straight-t025-a000
0
1
0 0 36 37
1
end_operator
begin_operator
move s2171 s571 lat-straight-rm45p0
0
1
0 0 36 75
1
end_operator
begin_operator
move s2193 s1393 lat-straight-rm22p5
0
1
0 0 37 11
1
end_operator
begin_operator
move s2193 s1793 lat-straight-rm05p6
0
1
0 0 37 22
1
end_operator
begin_operator
move s2193 s2153 lat-straight-t025-a135
0
1
0 0 37 34
1
end_operator
begin_operator
move s2193 s2154 lat-straight-t025-a090
0
1
0 0 37 35
1
end_operator
begin_operator
move s2193 s2171 lat-straight-t025-a180
0
1
0 0 37 36
1
end_operator
begin_operator
move s2193 s593 lat-straight-rm45p0
0
1
0 0 37 77
1
end_operator
begin_operator
move s2527 s2127 lat-straight-rm05p6
0
1
0 0 47 30
1
end_operator
begin_operator
move s2527 s2486 lat-straight-t025-a135
0
1
0 0 47 44
1
end_operator
begin_operator
move s2527 s2488 lat-straight-t025-a090
0
1
0 0 47 45
1
end_operator
begin_operator
move s2527 s2509 lat-straight-t025-a045
0
1
0 0 47 46
1
end_operator
begin_operator
move s2527 s2549 lat-straight-t025-a000
0
1
0 0 47 48
1
end_operator
begin_operator
move s2527 s3327 lat-straight-rp22p5
0
1
0 0 47 51
1
end_operator
begin_operator
move s2527 s4127 lat-straight-rp45p0
0
1
0 0 47 66
1
end_operator
begin_operator
move s3727 s2927 lat-straight-rm22p5
0
1
0 0 57 49
1
end_operator
begin_operator
move s3727 s3327 lat-straight-rm05p6
0
1
0 0 57 51
1
end_operator
begin_operator
move s3727 s3687 lat-straight-t025-a090
0
1
0 0 57 53
1
end_operator
begin_operator
move s3727 s3688 lat-straight-t025-a045
0
1
0 0 57 54
1
end_operator
begin_operator
move s3727 s3729 lat-straight-t025-a000
0
1
0 0 57 58
1
end_operator
begin_operator
move s3727 s4527 lat-straight-rp22p5
0
1
0 0 57 71
1
end_operator
begin_operator
move s3727 s5327 lat-straight-rp45p0
0
1
0 0 57 74
1
end_operator
begin_operator
move s3749 s2149 lat-straight-rm45p0
0
1
0 0 59 33
1
end_operator
begin_operator
move s3749 s2949 lat-straight-rm22p5
0
1
0 0 59 50
1
end_operator
begin_operator
move s3749 s3349 lat-straight-rm05p6
0
1
0 0 59 52
1
end_operator
begin_operator
move s3749 s3709 lat-straight-t025-a090
0
1
0 0 59 55
1
end_operator
begin_operator
move s3749 s3710 lat-straight-t025-a045
0
1
0 0 59 56
1
end_operator
begin_operator
move s3749 s3727 lat-straight-t025-a135
0
1
0 0 59 57
1
end_operator
begin_operator
move s3749 s3751 lat-straight-t025-a000
0
1
0 0 59 60
1
end_operator
begin_operator
move s3749 s3767 lat-straight-t025-a180
0
1
0 0 59 61
1
end_operator
begin_operator
move s4127 s2527 lat-straight-rm45p0
0
1
0 0 66 47
1
end_operator
begin_operator
move s4127 s3327 lat-straight-rm22p5
0
1
0 0 66 51
1
end_operator
begin_operator
move s4127 s3727 lat-straight-rm05p6
0
1
0 0 66 57
1
end_operator
begin_operator
move s4127 s4086 lat-straight-t025-a090
0
1
0 0 66 62
1
end_operator
begin_operator
move s4127 s4088 lat-straight-t025-a045
0
1
0 0 66 63
1
end_operator
begin_operator
move s4127 s4105 lat-straight-t025-a135
0
1
0 0 66 64
1
end_operator
begin_operator
move s4127 s4109 lat-straight-t025-a000
0
1
0 0 66 65
1
end_operator
begin_operator
move s4127 s4927 lat-straight-rp22p5
0
1
0 0 66 73
1
end_operator
begin_operator
move s4127 s5727 lat-straight-rp45p0
0
1
0 0 66 76
1
end_operator
begin_operator
move s4527 s2927 lat-straight-rm45p0
0
1
0 0 71 49
1
end_operator
begin_operator
move s4527 s3727 lat-straight-rm22p5
0
1
0 0 71 57
1
end_operator
begin_operator
move s4527 s4127 lat-straight-rm05p6
0
1
0 0 71 66
1
end_operator
begin_operator
move s4527 s4486 lat-straight-t025-a090
0
1
0 0 71 67
1
end_operator
begin_operator
move s4527 s4487 lat-straight-t025-a045
0
1
0 0 71 68
1
end_operator
begin_operator
move s4527 s4509 lat-straight-t025-a000
0
1
0 0 71 69
1
end_operator
begin_operator
move s4527 s4525 lat-straight-t025-a135
0
1
0 0 71 70
1
end_operator
begin_operator
move s4527 s4545 lat-straight-t025-a180
0
1
0 0 71 72
1
end_operator
begin_operator
move s4527 s5327 lat-straight-rp22p5
0
1
0 0 71 74
1
end_operator
begin_operator
visit s2127 g0
1
0 30
1
0 2 -1 0
1
end_operator
begin_operator
visit s4127 g1
1
0 66
1
0 1 -1 0
1
end_operator
0
