#!/usr/bin/env python3
"""Fits the polynomials of src/math.rs (atan_unit, sin_cos_poly) by Lawson's iteratively
reweighted least squares (a minimax approximation) in float64, and prints them rounded to
float32 with the maximum absolute error of the fit. Needs numpy: python3 scripts/fit_poly.py"""
import numpy as np
def lawson(f, w, lo, hi, deg, iters=300):
    # minimax-ish fit of f on [lo,hi] by Lawson's iteratively reweighted least squares, error weighted by w
    n=4000
    x=(lo+hi)/2+(hi-lo)/2*np.cos(np.pi*(np.arange(n)+0.5)/n)
    V=np.vander(x,deg+1,increasing=True)
    fx=f(x); wx=w(x)
    lw=np.ones(n)/n
    for _ in range(iters):
        A=V*(wx*np.sqrt(lw))[:,None]; b=fx*wx*np.sqrt(lw)
        c=np.linalg.lstsq(A,b,rcond=None)[0]
        e=np.abs((V@c-fx)*wx)
        lw=lw*e; lw/=lw.sum()
    return c, e.max()
# atan(s) = s + s*t*u(t), t = s^2, s in [0,1]
t0=1e-6
c,e=lawson(lambda t:(np.arctan(np.sqrt(t))/np.sqrt(t)-1)/t, lambda t: np.sqrt(t)*t, t0, 1.0, 7)
print("atan u", [float(np.float32(v)) for v in c], e)
# sin(r) = r + r*t*S(t), t=r^2, r in [-pi/4,pi/4]
q=(np.pi/4)**2
c,e=lawson(lambda t:(np.sin(np.sqrt(t))/np.sqrt(t)-1)/t, lambda t: np.sqrt(t)*t, t0, q, 3)
print("sin S", [float(np.float32(v)) for v in c], e)
# cos(r) = 1 - t/2 + t*t*C(t)
c,e=lawson(lambda t:(np.cos(np.sqrt(t))-1+t/2)/(t*t), lambda t: t*t, t0, q, 3)
print("cos C", [float(np.float32(v)) for v in c], e)
