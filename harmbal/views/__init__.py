"""The views stage, the public xarray views of one evaluation: the time domain
(:func:`harmbal.simulate`), the order spectrum (:func:`harmbal.order_spectrum`)
and the crank stars (:func:`harmbal.stars`).

Each builder takes an :class:`harmbal.views.evaluation.Evaluation` (the
unit-speed evaluation, the gas loads and the FFT backend, with the quantities
derived from them computed once on first use), the speeds and the shared
attributes: a new view is one builder and one line in :func:`harmbal.analyse`."""
