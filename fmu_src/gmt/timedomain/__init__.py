"""Time-domain magnetics: the paper's loss separation for any drive waveform.

The paper's complex permeability (eqs 3-5, 13-20) holds for one sinusoid. Its
loss separation (eqs 7-12) is Bertotti's, and in the time domain the same
three losses are a separation of the applied field,

    H = H_hys(B, history) + k_e dB/dt + k_ex |dB/dt|^(1/2) sign(dB/dt),

which holds for any current. One module per concern:

=====================  ==============================================
module                 contents
=====================  ==============================================
``separation``         k_e, k_ex from K_e, K_ex (eqs 9, 11); the
                       excess-loss constant C = 8.7635 in closed form
``hysteresis``         the rate-independent part: a stop-operator
                       (Prandtl-Ishlinskii) model with memory, loss
                       K_h B_m^n per cycle (eq 7)
``dynamic``            the extended dynamic loss law: a rate field
                       steeper than eddy currents and a relaxation
                       (Maxwell element), with closed-form losses
                       per cycle for segment waveforms and sinusoids
``parameters``         what the time domain adds to Table 2
                       (reversible curve, the Steinmetz law's range)
``magnetics``          B from the current per step (implicit, stable),
                       M, lambda, F (eqs 1, 25, 28) and eq 27
``inverse``            the explicit inverse for any demanded stroke,
                       and its sampled compensator
``steady``             the model under a sinusoid in the paper's terms
                       (B_m, mu', mu'', lag, loss); the fit of the
                       reversible curve to Table 1; both models side
                       by side
``transducer``         the parts gmt.Transducer builds for
                       magnetics="time_domain"
=====================  ==============================================
"""
